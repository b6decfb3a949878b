"""A held log read at its source's rate (roadbank.estimators.AtSource, signals.held_copies): the truth is the same
estimator run on the sensor's own log, the rows a logger wrote by holding its frames."""

from __future__ import annotations

import numpy as np
import pytest

from roadbank import Signals
from roadbank import estimators as E
from roadbank.signals import HELD_SHARE, held_copies, is_held
from roadbank.vehicle import conditions, for_log, log_conditions


def _source(n: int = 600, rate: float = 10.0, seed: int = 0, p: bool = True) -> Signals:
    """A 10 Hz drive with a jittered clock: weaving at 15 m/s on a 3 deg bank, noisy ay, a roll rate."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate + rng.uniform(-0.01, 0.01, n)
    t[0] = 0.0
    w = 0.3 * np.sin(2 * np.pi * 0.1 * t)
    vx = 15.0 + 0.5 * np.sin(0.05 * t)
    r = 0.1 * np.sin(2 * np.pi * 0.05 * t)
    ay = vx * r + 9.81 * np.sin(np.radians(3.0) + 0.01 * w) + 0.2 * rng.standard_normal(n)
    roll = 0.002 * np.cos(2 * np.pi * 0.1 * t) + 0.001 * rng.standard_normal(n) if p else None
    return Signals(t, vx, ay, r, np.full(n, np.nan), roll)


def _held(s: Signals, rate: float) -> tuple[Signals, np.ndarray]:
    """``s`` written onto a ``rate`` (Hz) grid by holding each frame, and the frame each row holds."""
    t = s.t[0] + np.arange(int((s.t[-1] - s.t[0]) * rate) + 1) / rate
    last = np.searchsorted(s.t, t, side="right") - 1
    return Signals(**{c: t if c == "t" else getattr(s, c)[last] for c in s.channels}), last


def test_held_copies_are_the_rows_that_repeat_a_frame():
    s = _source()
    h, last = _held(s, 100.0)
    copies = held_copies(h)
    assert np.array_equal(copies, np.r_[False, np.diff(last) == 0])
    assert not held_copies(s).any()                     # a log at its sensor's rate repeats nothing
    assert is_held(copies, h.vx > 5) and not is_held(held_copies(s), s.vx > 5)
    # a NaN repeats nothing; a piece's first row repeats the row before it where given
    ay = np.array(h.ay)
    ay[5:8] = np.nan
    assert not held_copies(Signals(h.t, h.vx, ay, h.r, h.delta_f, h.p))[5:8].any()
    first = (float(h.ay[9]), float(h.r[9]), float(np.asarray(h.p)[9]))
    assert held_copies(h[10:], first)[0] == copies[10]
    # held onto a grid twice the sensor's rate: about half the rows repeat, the share the rule reads as held
    c2 = held_copies(_held(s, 20.0)[0])
    assert abs(c2.mean() - HELD_SHARE) < 0.05


@pytest.mark.filterwarnings("ignore:pif-modified. its weights:RuntimeWarning")
@pytest.mark.parametrize("name", ["kinematic-lp", "kinematic-gyro", "pif-modified"])
def test_a_held_log_gives_the_sensors_own_log_on_the_rows_taken(name):
    """On the rows that bring new values the outputs are those of the estimator on the sensor's own log (stamps on
    the logger's grid); every copy gets the output of the row it repeats."""
    s = _source()
    h, last = _held(s, 100.0)
    taken = np.flatnonzero(~held_copies(h))
    inner = E.make(name).run(h.take(taken))
    out = E.AtSource(E.make(name)).run(h)
    assert np.array_equal(out.t, h.t) and len(out.theta) == len(h)
    frame = np.searchsorted(taken, np.maximum.accumulate(np.where(held_copies(h), -1, np.arange(len(h)))))
    for field in ("w", "theta", "phi_b", "valid", "settled"):
        assert np.array_equal(getattr(out, field), getattr(inner, field)[frame], equal_nan=field not in
                              ("valid", "settled"))
    for k, v in inner.states.items():
        assert np.array_equal(out.states[k], v[frame], equal_nan=True)


def test_pieces_and_steps_give_the_run():
    s = _source()
    h, _ = _held(s, 50.0)
    whole = E.AtSource(E.make("kinematic-gyro")).run(h)
    est = E.AtSource(E.make("kinematic-gyro"))
    parts = [est.run(h[a:a + 37], reset=(a == 0)) for a in range(0, len(h), 37)]
    assert np.array_equal(np.concatenate([p.theta for p in parts]), whole.theta)
    assert np.array_equal(np.concatenate([p.valid for p in parts]), whole.valid)
    k = int(np.flatnonzero(held_copies(h) & (np.arange(len(h)) > 50))[0])
    est.run(h[:k])                    # a run, then steps: a copy of its last row repeats its last output
    assert est.step(h.t[k], h.vx[k], h.ay[k], h.r[k], p=float(np.asarray(h.p)[k])).theta == whole.theta[k - 1]
    est.reset()
    steps = [est.step(h.t[i], h.vx[i], h.ay[i], h.r[i], p=float(np.asarray(h.p)[i])) for i in range(len(h))]
    np.testing.assert_allclose([x.theta for x in steps], whole.theta, rtol=0, atol=1e-12)
    assert [x.valid for x in steps] == whole.valid.tolist()


def test_a_piece_of_copies_alone_repeats_the_last_output():
    h, _ = _held(_source(), 100.0)
    copies = held_copies(h)
    a = int(np.flatnonzero(copies & (np.arange(len(h)) > 400))[0])      # a run of copies, rows a..b-1
    b = a + int(np.argmax(~copies[a:]))
    assert 0 < b - a < 10
    est = E.AtSource(E.make("kinematic-lp"))
    first = est.run(h[:a])
    same = est.run(h[a:b], reset=False)
    assert np.all(same.theta == first.theta[-1]) and np.all(same.valid == first.valid[-1])
    assert np.array_equal(same.t, h.t[a:b])
    fresh = E.AtSource(E.make("kinematic-lp")).run(h[a:b])     # after a reset its first row repeats nothing
    assert fresh.valid[0] and not held_copies(h[a:b])[0]


def test_the_online_learner_goes_behind_the_reading_at_source():
    h, _ = _held(_source(), 100.0)
    est = E.with_online_offsets(E.AtSource(E.make("kinematic-lp")))
    assert isinstance(est, E.AtSource) and isinstance(est.inner, E.OnlineOffsets)
    taken = np.flatnonzero(~held_copies(h))
    inner = E.with_online_offsets(E.make("kinematic-lp")).run(h.take(taken))
    assert np.array_equal(est.run(h).theta[taken], inner.theta)
    with pytest.raises(ValueError, match="already reads"):
        E.AtSource(est)


def test_the_design_reads_a_held_log_at_its_sources_rate(monkeypatch):
    """With READ_AT_SOURCE, a held log is designed for its sensor's rate and read through AtSource; a log at its
    sensor's rate gets what it got without."""
    s = _source(1200, seed=1)
    h, _ = _held(s, 100.0)
    monkeypatch.setattr(conditions, "READ_AT_SOURCE", True)
    cond = log_conditions(h)
    assert cond.get("log_held") == 1.0 and abs(cond["log_rate"] - 10.0) < 0.5
    assert isinstance(for_log("kinematic-pif", h), E.AtSource)
    own = log_conditions(s)
    assert "log_held" not in own and not isinstance(for_log("kinematic-pif", s), E.AtSource)
    monkeypatch.setattr(conditions, "READ_AT_SOURCE", False)
    assert log_conditions(s) == own and "log_held" not in log_conditions(h)


@pytest.mark.parametrize("name", ["kinematic-smoother", "kinematic-gyro-smoother"])
def test_an_offline_estimator_in_pieces_with_its_lookahead_gives_the_run(name):
    """As roadbank map runs it: chunks, each with the samples after it as lookahead (copies among them too)."""
    h, _ = _held(_source(1200, seed=1), 100.0)
    whole = E.AtSource(E.make(name)).run(h)
    est = E.AtSource(E.make(name))
    parts = []
    for a in range(0, len(h), 997):
        piece = h[a:a + 997]
        ahead = np.flatnonzero((h.t > piece.t[-1]) & (h.t <= piece.t[-1] + est.lookahead_s))
        parts.append(est.run(piece, reset=(a == 0), lookahead=h.take(ahead) if ahead.size else None))
    np.testing.assert_allclose(np.concatenate([p.theta for p in parts]), whole.theta, rtol=0, atol=1e-9)


def test_the_plain_command_reads_a_held_csv_at_its_sources_rate(tmp_path):
    """`roadbank estimate LOG -o out.csv` on a CSV a logger wrote at 100 Hz from 10 Hz frames: the design line says
    so, every row is written, and a row that repeats a frame repeats its output."""
    import pandas as pd
    from click.testing import CliRunner

    from roadbank.cli import main

    h, _ = _held(_source(1200, seed=1), 100.0)
    log = tmp_path / "held.csv"
    pd.DataFrame({"t": h.t, "vx": h.vx, "ay": h.ay, "r": h.r}).to_csv(log, index=False)
    out = tmp_path / "out.csv"
    res = CliRunner().invoke(main, ["estimate", str(log), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "written by holding its sensors' frames, read at their rate, 10 Hz" in res.output
    theta = pd.read_csv(out)["kinematic-pif.theta"].to_numpy()
    copies = held_copies(Signals(h.t, h.vx, h.ay, h.r, h.delta_f))
    assert len(theta) == len(h) and np.array_equal(theta[1:][copies[1:]], theta[:-1][copies[1:]])
    assert np.count_nonzero(np.diff(theta)[~copies[1:]]) > 0.8 * np.count_nonzero(~copies[1:])


@pytest.mark.parametrize("noise", [1.0, 0.5, 0.2])
def test_a_quantised_sensor_at_its_own_rate_is_not_held(noise):
    """The simulator's 100 Hz ESP channels are quantised (ay 0.005 g, yaw rate 0.3 deg/s): with less noise than the
    data sheet's (the campaign draws 0.5-2 times it) a quarter to nearly all of the rows repeat the one before, at
    random; that is no logger's hold, and the log is read whole."""
    import dataclasses

    from roadbank.sim import sensors as S
    from roadbank.sim.scenarios import run_scenario

    cfg = S.SensorConfig()
    cfg = dataclasses.replace(cfg, yaw_rate=dataclasses.replace(cfg.yaw_rate, noise_std=cfg.yaw_rate.noise_std * noise),
                              ay=dataclasses.replace(cfg.ay, noise_std=cfg.ay.noise_std * noise))
    s = run_scenario("const-bank", sensors=cfg).signals
    copies = held_copies(s)
    assert copies[s.vx > 5].mean() > (0.9 if noise == 0.2 else 0.2)
    assert not is_held(copies, s.vx > 5)
    assert "log_held" not in log_conditions(s)
    # the same drive's 10 Hz frames held onto a 100 Hz grid are (with a tenth of the noise they repeat each other
    # too, 99.8 % of the rows: there the hold and the sensor's own repeats cannot be told apart, nor need they be)
    h, _ = _held(s.take(np.arange(0, len(s), 10)), 100.0)
    assert is_held(held_copies(h), h.vx > 5) == (noise >= 0.5)
