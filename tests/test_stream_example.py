"""examples/stream.py: sample-by-sample step() equals the batch run() exactly."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from roadbank import Signals, estimators

ROOT = Path(__file__).resolve().parents[1]
SEGMENT = ROOT / ".." / "shared" / "data" / "comma2k19-example"


def _example():
    spec = importlib.util.spec_from_file_location("stream_example", ROOT / "examples" / "stream.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _signals():
    if SEGMENT.is_dir():
        from roadbank.io import load_log
        return load_log(SEGMENT).signals[:2000]
    # synthetic fallback with a low-speed stretch and a dropout
    t = np.arange(1500) * 0.01
    vx = np.where(t < 2, 3.0, 20.0)
    ay = 0.5 * np.sin(t) + 0.3
    r = 0.02 * np.sin(t)
    d = 0.01 * np.sin(t)
    ay[700] = np.nan
    return Signals(t, vx, ay, r, d)


@pytest.mark.parametrize("name", ["kinematic", "pif-modified", "kalman"])
def test_stream_equals_batch(name):
    s = _signals()
    out = _example().stream(s, name)
    batch = estimators.make(name).run(s)
    np.testing.assert_array_equal(out["valid"], batch.valid)
    np.testing.assert_allclose(out["theta"], batch.theta, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["phi_b"], batch.phi_b, rtol=0, atol=1e-12)


def test_stream_main_runs(capsys):
    if not SEGMENT.is_dir():
        pytest.skip(f"comma2k19 example segment absent at {SEGMENT}")
    _example().main([str(SEGMENT), "--estimator", "kinematic"])
    assert "max |stream - batch| = 0" in capsys.readouterr().out
