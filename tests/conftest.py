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


@pytest.fixture
def c_restarts_as_alone(tmp_path):
    """``check(est, log, b, k, rate)``: ``est`` (a ``KinematicGyro`` with its grade correction) exported to C and
    compiled: on ``log`` (a drive, a gap longer than ``est.max_gap``, then drive ``b`` from row ``k``) the C module's
    corrected roll rate equals ``est.grade``'s (NaN where it is) and its estimate ``est.run``'s to 1e-9 rad, and its
    roll rate and estimate of ``b`` from the restart on equal its run of ``b`` alone; ``rate`` (Hz) the export's.
    A log without ``q`` gives the C module NaN for it (the window's path)."""
    from roadbank.export import CModule, export_c

    def check(est, log, b, k, rate):
        ref = est.run(log)
        est.grade.reset()
        py_rate = est.grade.correct(log).p
        mod = CModule(export_c(est, tmp_path, rate=rate).source, tmp_path)
        assert mod.has_grade

        def c_run(s):
            q = s.q if s.q is not None else np.full(len(s), np.nan)
            roll = mod.roll_rates(s.t, s.vx, s.ay, s.r, s.p, s.ax, q)
            return roll, mod.run(s.t, s.vx, s.ay, s.r, roll)
        roll, c = c_run(log)
        np.testing.assert_array_equal(np.isnan(roll), np.isnan(py_rate))
        assert np.nanmax(np.abs(roll - py_rate)) <= 1e-9
        np.testing.assert_array_equal(c["valid"], ref.valid)
        assert np.max(np.abs(c["theta"] - ref.theta)) <= 1e-9
        roll_b, c_b = c_run(b)
        assert np.nanmax(np.abs(roll[k:] - roll_b)) <= 1e-9
        assert np.max(np.abs(c["theta"][k:] - c_b["theta"])) <= 1e-9
    return check
