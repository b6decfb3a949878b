"""Shared test fixtures: a linear bicycle plant simulated by scipy (independent of roadbank's kernels)."""

from __future__ import annotations

import os

# Small matrices everywhere (3x3..6x6 designs): a multi-threaded BLAS only spins, and on a
# loaded 2-core machine it made each gain-schedule design 10-20x slower. As the CLI does.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
# the command line's last-resort one-line message hides a bug's traceback from a user; the tests want the bug itself
# (tests/test_cli_safety_net.py checks the message with it unset)
os.environ["ROADBANK_TRACEBACK"] = "1"

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy.signal import StateSpace as ScipySS  # noqa: E402
from scipy.signal import lsim  # noqa: E402

from roadbank import Signals, VehicleParams  # noqa: E402

DATA_DIR = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def linear_plant_run(params: VehicleParams, *, vx=22.2, bank_deg=5.0, delta=0.01, t_step=2.0,
                     T=30.0, fs=100.0):
    """Simulate the *original* bicycle model of ``params`` with scipy.signal.lsim.

    Constant ``w = sin(bank)``, a road-wheel angle step of ``delta`` rad at
    ``t_step``; the plant starts in steady state. Returns (Signals, w). The
    plant matrices are written out here from SPEC 3.1, not taken from roadbank.
    """
    m, Iz, Lf, Lr, Cf, Cr, g = params.m, params.Iz, params.Lf, params.Lr, params.Cf, params.Cr, params.g
    A = np.array([[-(Cf + Cr) / (m * vx), -vx - (Lf * Cf - Lr * Cr) / (m * vx)],
                  [-(Lf * Cf - Lr * Cr) / (Iz * vx), -(Lf**2 * Cf + Lr**2 * Cr) / (Iz * vx)]])
    B = np.array([[Cf / m, -g], [Lf * Cf / Iz, 0.0]])          # inputs [delta_f, w]
    C = np.array([[-(Cf + Cr) / (m * vx), -(Lf * Cf - Lr * Cr) / (m * vx)], [0.0, 1.0]])
    D = np.array([[Cf / m, 0.0], [0.0, 0.0]])
    t = np.arange(0.0, T, 1.0 / fs)
    w = np.sin(np.deg2rad(bank_deg))
    d = np.where(t > t_step, delta, 0.0)
    U = np.column_stack([d, np.full_like(t, w)])
    x0 = -np.linalg.solve(A, B @ U[0])
    _, y, _ = lsim(ScipySS(A, B, C, D), U, t, X0=x0)
    return Signals(t, np.full_like(t, vx), y[:, 0], y[:, 1], d), w


@pytest.fixture(scope="session")
def params():
    return VehicleParams()
