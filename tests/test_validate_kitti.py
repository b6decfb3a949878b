"""``roadbank validate kitti`` / ``validate all``, the shared scoring, and the estimators at 10 Hz with jitter."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.vehicle.factory import NOT_FITTED
from roadbank.validation.jitter import jitter_study
from roadbank.validation.scoring import Scoring, lowpass, lowpass_t, masks, pooled, score

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
KITTI = DATA / "kitti-oxts"
needs_kitti = pytest.mark.skipif(not any(KITTI.glob("*/oxts")), reason=f"KITTI oxts drives absent at {KITTI}")
STEERING = {"dfc", "uio", "pio-original", "pif-original", "kalman"}   # read delta_f, absent on KITTI
CLI_NAMES = ("kinematic", "pio-modified", "pif-modified", "uio")          # uio: one that needs the steering
#: raw RMS (deg) against the INS roll per shared drive and estimator (docs/real-data.md); a drive added to the
#: folder has none and is bounded by the generic checks only
RAW_DOCUMENTED = {"2011_09_26_drive_0070": {"kinematic": 0.597, "pif-modified": 0.431},
                  "2011_10_03_drive_0047": {"kinematic": 0.403, "pif-modified": 0.302}}


# ---------------------------------------------------------------- scoring (dataset-independent)
def test_masks_gate_and_warmup_restart():
    t = np.arange(0.0, 40.0, 0.1)
    vx = np.where((t >= 10) & (t < 12), 2.0, 10.0)      # 2 s below the gate: a restart
    fit, sc = masks(t, vx, Scoring(fit_fraction=0.0, warmup_s=5.0))
    assert not fit.any()
    expect = ((t >= 5.0) & (t < 10.0)) | (t >= 17.0 - 1e-9)
    np.testing.assert_array_equal(sc, expect)
    # a short dip (< max_gap) does not restart the warm-up, the dip itself is not scored
    vx2 = np.where((t >= 10) & (t < 10.5), 2.0, 10.0)
    _, sc2 = masks(t, vx2, Scoring(fit_fraction=0.0))
    np.testing.assert_array_equal(sc2, (t >= 5.0) & ~((t >= 10) & (t < 10.5 - 1e-9)))
    fit3, sc3 = masks(t, np.full_like(t, 10.0), Scoring(fit_fraction=0.3))
    n = int(np.sum(t >= 5.0))
    assert fit3.sum() == int(0.3 * n) and sc3.sum() == n - int(0.3 * n) and not (fit3 & sc3).any()


def test_masks_warmup_from_the_log_start_scores_the_seconds_after_a_stop():
    t = 50.0 + np.arange(0.0, 40.0, 0.1)                  # the log does not start at 0
    rel = t - t[0]
    vx = np.where((rel >= 10) & (rel < 12), 2.0, 10.0)     # 2 s below the gate
    vx[:20] = 0.0                                          # parked for the first 2 s
    fit, sc = masks(t, vx, Scoring(fit_fraction=0.0, from_log_start=True))
    assert not fit.any()
    np.testing.assert_array_equal(sc, (rel >= 5.0 - 1e-9) & (vx >= 5.0))
    # the each-start scoring drops the 5 s after the dip and after the first moving sample
    _, each = masks(t, vx, Scoring(fit_fraction=0.0))
    assert not (each & ~sc).any() and sc[(rel >= 12) & (rel < 17)].all() and not each[(rel >= 12) & (rel < 16.9)].any()


def test_lowpass_on_jittered_time_is_first_order():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.06, 0.14, 400))
    np.testing.assert_allclose(lowpass_t(np.ones(400), t, 0.5), 1.0)
    # causal step response of 1/(tau s + 1) sampled at jittered instants: 1 - exp(-t/tau) within 5 %
    y = lowpass_t(np.r_[0.0, np.ones(399)], t, 2.0, zero_phase=False)
    k = np.searchsorted(t - t[1], 2.0)
    assert y[k] == pytest.approx(1 - np.exp(-(t[k] - t[1]) / 2.0), abs=0.05)
    tu = np.arange(300) * 0.01                          # uniform: exactly the scipy path
    x = np.sin(tu)
    np.testing.assert_allclose(lowpass_t(x, tu, 0.3), lowpass(x, 0.3, 0.01), rtol=1e-12)


def test_score_offset_and_rms_against_known_errors():
    t = np.arange(0.0, 60.0, 0.1)
    ref = np.radians(2.0) * np.sin(0.3 * t)
    est = ref - np.radians(0.4)                          # a constant bias of 0.4 deg
    valid = np.ones(len(t), bool)
    for frac, rms in ((0.0, 0.4), (0.3, 0.0)):          # no offset: the bias counts; fitted: removed
        sc_ = Scoring(fit_fraction=frac)
        fit, sc = masks(t, np.full_like(t, 10.0), sc_)
        s = score(t, est, est, valid, ref, fit, sc, sc_)
        assert s.rms_raw_deg == pytest.approx(rms, abs=1e-9)
        assert s.rms_deg == pytest.approx(rms, abs=2e-3) and s.r_raw == pytest.approx(1.0)
    none = score(t, est, est, np.zeros(len(t), bool), ref, fit, sc, sc_)
    assert np.isnan(none.rms_raw_deg) and none.valid_fraction == 0.0


# ---------------------------------------------------------------- the real drives
@pytest.fixture(scope="module")
def kitti_cli(tmp_path_factory):
    out = tmp_path_factory.mktemp("kitti") / "real-data.md"
    res = CliRunner().invoke(main, ["validate", "kitti", str(KITTI), "--json", "-o", str(out),
                                    "-e", ",".join(CLI_NAMES)])
    return res, out


@pytest.mark.slow
@needs_kitti
def test_validate_kitti_json_report_and_figures(kitti_cli):
    res, out = kitti_cli
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    drives = sorted(p.parent.name for p in KITTI.glob("*/oxts"))
    assert sorted(data["drives"]) == drives and data["errors"] == []
    assert set(RAW_DOCUMENTED) <= set(data["drives"])          # the documented drives are scored
    for drive, scores in data["drives"].items():
        assert set(scores) == set(CLI_NAMES)
        for name, v in scores.items():
            if name in STEERING:
                assert v["rms_raw_deg"] is None        # no steering angle on KITTI: no valid sample
            else:
                assert 0 < v["rms_raw_deg"] < 3 and v["offset_deg"] == 0.0
        # the raw RMS against the INS roll as docs/real-data.md has it, within a quarter
        for name, documented in RAW_DOCUMENTED.get(drive, {}).items():
            assert scores[name]["rms_raw_deg"] < 1.25 * documented, (drive, name)
        # README: corr(roll, (ay - vx wz)/g) = 0.96 / 0.94 over the whole drive
        assert scores["kinematic"]["r_raw"] > 0.9
        assert (out.parent / f"real-data-kitti-{drive}.png").exists()
    # pooled raw RMS^2 is the sample-weighted mean of the drives' (no offset on KITTI)
    text = out.read_text()
    assert "| pif-modified |" in text and "Pooled" in text
    for name in ("kinematic", "pif-modified"):
        assert data["pooled"][name]["n"] > 0
    from roadbank.validation.splits import split_of

    in_validation = [d for d in drives if split_of(d) == "validation"]      # the two shared ones, at least
    assert {"2011_09_26_drive_0070", "2011_10_03_drive_0047"} <= set(in_validation)
    assert "Training and validation drives" in text and f"**validation** ({len(in_validation)} drives)" in text
    assert data["splits"]["validation"]["drives"] == in_validation and data["flagged"] == []
    # each drive's design: the rule's car for a loud 10 Hz INS log (its floor several times the data sheet's)
    for drive in {"2011_09_26_drive_0070", "2011_10_03_drive_0047"} & set(drives):      # measured: 6.6x, 3.7x
        design = data["designs"][drive]
        # the default reads the drive's roll rate, which has no car model: the static car, not fitted
        assert design["car"] == "sedan" and design["car_from"] == NOT_FITTED and design["quiet"] is False
        assert design["ay_floor_ratio"] > 3.0 and design["ay_floor"] <= design["ay_noise"]
        assert f"sedan, loud ({design['ay_floor_ratio']:.2g} x)" in text


def test_default_pif_noise_density_follows_the_log_rate():
    from roadbank.estimators.pif import R_ESP
    from roadbank.validation.scoring import log_rate_R

    rng = np.random.default_rng(0)
    t10 = np.cumsum(rng.uniform(0.06, 0.14, 500))             # KITTI-like jitter around 0.1 s
    assert log_rate_R(np.arange(1000) * 0.01) == pytest.approx(R_ESP, rel=1e-9)
    assert log_rate_R(t10) == pytest.approx(R_ESP * 100.0 / (1.0 / np.median(np.diff(t10))), rel=1e-9)
    assert log_rate_R(t10) == pytest.approx(10 * R_ESP, rel=0.05)


@pytest.fixture(scope="module")
def kitti_default():
    from roadbank.validation.kitti import validate_kitti

    # the two drives of this folder the claims below were made on (others may join the folder)
    return validate_kitti([KITTI / "2011_09_26_drive_0070", KITTI / "2011_10_03_drive_0047"],
                          names=["kinematic", "pif-modified"], sensitivity=False)


@needs_kitti
def test_the_seconds_after_each_stop_are_scored_and_the_each_start_column_leaves_them_out(kitti_default):
    """KITTI_SCORING scores every sample at vx >= 5 m/s from 5 s after the drive's first, the seconds
    after each stop included; KITTI_SCORING_EACH_START (the last column) a subset, smaller on a drive
    that stops (0047 does). Each drive's rms_raw_each_start_deg is the raw RMS of the held estimate
    on that subset, and the split's median is theirs."""
    from roadbank.validation.kitti import KITTI_SCORING, KITTI_SCORING_EACH_START

    for d in kitti_default.drives:
        run, vx = d.run, _vx(d)
        whole, each = masks(run.t, vx, KITTI_SCORING)[1], masks(run.t, vx, KITTI_SCORING_EACH_START)[1]
        np.testing.assert_array_equal(whole, run.scored)
        assert not (each & ~whole).any()
        for n in ("kinematic", "pif-modified"):
            e = run.raw_estimates[n][each] - run.raw_reference[each]
            assert d.data["rms_raw_each_start_deg"][n] == pytest.approx(np.degrees(np.sqrt(np.mean(e ** 2))),
                                                                       rel=1e-12)
    by = {d.label: d for d in kitti_default.drives}
    stopping = by["2011_10_03_drive_0047"]
    assert masks(stopping.run.t, _vx(stopping), KITTI_SCORING_EACH_START)[1].sum() < stopping.run.scored.sum()
    part = kitti_default.by_split["validation"]
    assert part["median_rms_raw_each_start_deg"]["kinematic"] == pytest.approx(
        np.median([by[x].data["rms_raw_each_start_deg"]["kinematic"] for x in part["drives"]]))


def _vx(drive_result):
    from roadbank.io.kitti import load_kitti_oxts
    return load_kitti_oxts(KITTI / drive_result.label).signals.vx


@needs_kitti
def test_default_pif_meets_the_kitti_target_on_every_drive(kitti_default):
    # issue 14's target, on validation data (never used for tuning); theta vs the INS roll,
    # unsmoothed: <= 0.5 deg and below the kinematic estimate
    assert len(kitti_default.drives) == 2
    for d in kitti_default.drives:
        assert d.scores["pif-modified"].rms_raw_deg <= 0.5, d.label
        assert d.scores["pif-modified"].rms_raw_deg < d.scores["kinematic"].rms_raw_deg, d.label


@needs_kitti
def test_pooled_equals_weighted_drive_rms(kitti_default):
    v = kitti_default
    for name in ("kinematic", "pif-modified"):
        ns = [int(d.run.scored.sum()) for d in v.drives]
        ms = [d.scores[name].rms_raw_deg ** 2 for d in v.drives]
        assert v.pooled[name]["rms_raw_deg"] == pytest.approx(np.sqrt(np.dot(ns, ms) / sum(ns)), rel=1e-9)
        assert v.pooled[name]["n"] == sum(ns)
    assert pooled([], ["kinematic"])["kinematic"]["n"] == 0


@needs_kitti
def test_one_bad_drive_does_not_lose_the_others(tmp_path):
    bad = tmp_path / "2011_01_01_drive_0009_sync" / "oxts"
    (bad / "data").mkdir(parents=True)
    (bad / "timestamps.txt").write_text("2011-01-01 12:00:00.0\nnot a time\n")
    good = next(KITTI.glob("*/oxts")).parent
    res = CliRunner().invoke(main, ["validate", "kitti", str(bad.parent), str(good), "--json", "--no-sensitivity",
                                    "-e", "kinematic"])
    assert res.exit_code == 1 and "Traceback" not in res.output
    data = json.loads(res.stdout)
    assert list(data["drives"]) == [good.name]
    assert "timestamps.txt: line 2: unparsable time stamp" in data["errors"][0]


def test_validate_kitti_nothing_readable(tmp_path):
    res = CliRunner().invoke(main, ["validate", "kitti", str(tmp_path)])
    assert res.exit_code == 1 and "not a KITTI raw drive" in res.output and "Traceback" not in res.output


# ---------------------------------------------------------------- 10 Hz with jitter
@pytest.mark.slow
def test_10hz_jitter_against_100hz_on_the_truth():
    r = jitter_study("bank-lane-change", names=("kinematic", "pio-modified", "pif-modified"))
    assert r.steps.min() >= 0.06 - 1e-9 and r.steps.max() <= 0.14 + 1e-9
    assert r.steps.mean() == pytest.approx(0.1, abs=0.01)
    assert r.substeps == (3, 7)                          # 20 ms substeps: 0.06 s -> 3, 0.14 s -> 7
    for name in r.rms_100hz:
        # the same run read at jittered 10 Hz is about as accurate against the truth as at 100 Hz
        assert r.rms_10hz[name] <= 1.2 * r.rms_100hz[name] + 0.05, (name, r.rms_100hz, r.rms_10hz)
    # the 20 ms substeps have converged at 10 Hz: 5 ms ones (16x smaller trapezoidal error) change
    # theta by far less than the 10 Hz accuracy itself
    for name, d in r.substep_diff.items():
        assert d["5ms"] < 0.02, (name, d)


# ---------------------------------------------------------------- the combined report
def test_find_datasets_layouts(tmp_path):
    from roadbank.validation.datasets import find_datasets

    (tmp_path / "seg" / "processed_log").mkdir(parents=True)
    for drive in ("kitti/2011_01_01_drive_0001_sync", "kitti/2011_01_01_drive_0002_sync"):
        (tmp_path / drive / "oxts" / "data").mkdir(parents=True)
        (tmp_path / drive / "oxts" / "timestamps.txt").write_text("2011-01-01 12:00:00.0\n")
    found = find_datasets(tmp_path)
    assert found["comma2k19"] == [tmp_path / "seg"]
    assert [p.name for p in found["kitti"]] == ["2011_01_01_drive_0001_sync", "2011_01_01_drive_0002_sync"]
    assert find_datasets(tmp_path / "kitti")["kitti"] == found["kitti"]


@pytest.mark.slow
@needs_kitti
def test_validate_all_writes_one_report(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    drive = next(KITTI.glob("*/oxts")).parent
    (data / drive.name).symlink_to(drive)                # KITTI only: no comma2k19 run, no jitter study
    out = tmp_path / "docs" / "real-data.md"
    res = CliRunner().invoke(main, ["validate", "all", str(data), "-o", str(out), "--no-jitter"])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert text.startswith("# Real-data validation") and "## Summary" in text
    from roadbank.validation.splits import split_of
    assert f"| KITTI | {drive.name} ({split_of(drive.name)}) |" in text and "## KITTI raw drives" in text
    assert (out.parent / f"real-data-kitti-{drive.name}.png").exists()
    empty = tmp_path / "empty"
    empty.mkdir()
    res = CliRunner().invoke(main, ["validate", "all", str(empty), "-o", str(out)])
    assert res.exit_code == 1 and "no comma2k19 segment or KITTI drive" in res.output


EXTRA = DATA / "kitti-oxts-extra"
needs_all_drives = pytest.mark.skipif(not EXTRA.is_dir(), reason="../shared/data/kitti-oxts-extra is not here")


@pytest.fixture(scope="module")
def validation_split():
    from roadbank.validation.kitti import validate_kitti

    names = ["kinematic", "kinematic-lp", "kinematic-ff", "kinematic-pif", "pif-modified", "pio-modified"]
    v = validate_kitti([KITTI, EXTRA], names=names, sensitivity=False)
    # the 16 drives of the split (more drives in the folders would be reported as unseen)
    assert len(v.by_split["training"]["drives"]) == 8 and len(v.by_split["validation"]["drives"]) == 8
    return v


@pytest.mark.slow
@needs_all_drives
def test_the_default_beats_the_baselines_on_the_validation_drives(validation_split):
    # the targets on the 8 validation drives (never used to choose) that hold: the default's median raw
    # RMS below the baseline to beat (kinematic-lp) and the raw kinematic estimate, below the raw
    # kinematic estimate on at least 90 % of the drives; the lowest of the causal estimators when the
    # seconds after each stop are left out (the each-start column)
    from roadbank.estimators import DEFAULT

    v = validation_split
    med = v.by_split["validation"]["median_rms_raw_deg"]
    assert DEFAULT == "kinematic-pif" and med[DEFAULT] < med["kinematic-lp"] < med["kinematic"], med
    each = v.by_split["validation"]["median_rms_raw_each_start_deg"]
    assert each[DEFAULT] <= min(each.values()) + 1e-12, each
    val = [d for d in v.drives if d.data["split"] == "validation"]
    below = [d.scores[DEFAULT].rms_raw_deg < d.scores["kinematic"].rms_raw_deg for d in val]
    assert sum(below) / len(below) >= 0.9


@pytest.mark.slow
@needs_all_drives
def test_the_default_is_the_lowest_causal_estimator_on_the_validation_drives(validation_split):
    """Met since the twenty-first stage (the noise read just above the dynamics band, chosen on training data):
    0.315 deg against kinematic-ff's 0.327 (before it 0.32804 against 0.32720, an expected failure; the default was
    lower on 7 of the 8 drives and drive 2011_09_30_drive_0020 decided the median of 8)."""
    from roadbank.estimators import DEFAULT

    med = validation_split.by_split["validation"]["median_rms_raw_deg"]
    assert med[DEFAULT] <= min(med.values()) + 1e-12, med


@needs_kitti
def test_a_drive_whose_ins_is_not_credible_is_flagged_and_not_pooled(tmp_path):
    import shutil

    from roadbank.validation.kitti import validate_kitti

    src = KITTI / "2011_09_26_drive_0070" / "oxts"
    bad = tmp_path / "2011_09_26_drive_0070" / "oxts"
    shutil.copytree(src, bad)
    for f in (bad / "data").iterdir():                  # the INS's leftward speed: 8 m/s
        vals = f.read_text().split()
        vals[9] = "8.0"
        f.write_text(" ".join(vals) + "\n")
    good = KITTI / "2011_10_03_drive_0047"
    v = validate_kitti([tmp_path / "2011_09_26_drive_0070", good], names=["kinematic"], sensitivity=False)
    assert [d for d, _ in v.flagged] == ["2011_09_26_drive_0070"]
    assert "leftward speed 8.0 m/s" in v.flagged[0][1]
    assert v.pooled["kinematic"]["n"] == int(v.drives[1].run.scored.sum())     # the credible drive only
    assert v.by_split["validation"]["drives"] == ["2011_10_03_drive_0047"]


# ---------------------------------------------------------------- speed-ups that must not change a number
def _steps_in_python(x, a):
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, len(x)):
        y[k] = y[k - 1] + a[k - 1] * (x[k] - y[k - 1])
    return y


def test_the_compiled_low_pass_gives_the_numbers_of_the_loop():
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.06, 0.14, 2000))
    x = np.cumsum(rng.normal(size=2000))
    d = np.diff(t)
    a = d / (0.7 + d)
    np.testing.assert_array_equal(lowpass_t(x, t, 0.7, zero_phase=False), _steps_in_python(x, a))
    back = _steps_in_python(_steps_in_python(x, a)[::-1], a[::-1])[::-1]
    np.testing.assert_array_equal(lowpass_t(x, t, 0.7), back)
    np.testing.assert_array_equal(lowpass_t(x[::3], t[::3], 0.7, zero_phase=False),        # strided input
                                  _steps_in_python(x[::3], np.diff(t[::3]) / (0.7 + np.diff(t[::3]))))


def test_best_lag_is_the_first_best_of_pearson_r_lag_by_lag():
    from roadbank.validation.scoring import best_lag, pearson_r

    def by_loop(x, ref, idx, lags):
        return max(((pearson_r(x[idx + k], ref[idx]), k) for k in lags),
                   key=lambda z: -np.inf if np.isnan(z[0]) else z[0])

    rng = np.random.default_rng(5)
    lags = np.arange(-10, 11)
    idx = np.arange(10, 990)
    ref = np.convolve(rng.normal(size=1000), np.ones(15) / 15, "same")
    for x in (np.roll(ref, 3) + 0.1 * rng.normal(size=1000),       # a clear best lag (3 samples)
              rng.normal(size=1000),                                # none
              np.tile(rng.normal(size=4), 250),                     # period 4: lags k, k+4 tie, the first wins
              np.r_[np.full(500, 0.2), ref[500:]]):                 # some lags see a constant part
        got, want = best_lag(x, ref, idx, lags), by_loop(x, ref, idx, lags)
        assert got[1] == want[1] and (got[0] == want[0] or np.isnan(got[0]) and np.isnan(want[0]))
    const = np.full(1000, 0.1)                                     # every lag NaN: the first lag
    assert best_lag(const, ref, idx, lags)[1] == by_loop(const, ref, idx, lags)[1] == -10
    assert best_lag(ref, ref, idx[:2], lags)[1] == -10             # too few samples


class _RecordingPool:
    """In-process tasks, run when submitted, in the order submitted (as a pool of workers sees them)."""

    in_process = False

    def __init__(self):
        self.order = []

    def submit(self, fn, path, *args):
        self.order.append(Path(path).name)
        return fn(path, *args)

    def outcome(self, task):
        return task, None


@needs_kitti
def test_figures_are_drawn_in_the_drives_tasks_longest_submitted_first(tmp_path):
    from roadbank.validation.kitti import drive_frames, validate_kitti
    from roadbank.validation.kitti_report import drive_png, plot_drive

    drives = [KITTI / "2011_09_26_drive_0070", KITTI / "2011_10_03_drive_0047"]
    frames = [drive_frames(d) for d in drives]
    assert frames == [len(list((d / "oxts" / "data").iterdir())) for d in drives] and frames[1] > frames[0]
    pool = _RecordingPool()
    v = validate_kitti(drives, names=["kinematic", "pif-modified"], sensitivity=False, pool=pool, figure=drive_png)
    assert pool.order == [drives[1].name, drives[0].name]                    # the longer drive first
    assert [d.label for d in v.drives] == [d.name for d in drives]           # reported in the order given
    plain = validate_kitti(drives, names=["kinematic", "pif-modified"], sensitivity=False)
    assert plain.figures == {} and plain.pooled == v.pooled
    for d in plain.drives:                                                    # the file plot_drive writes
        plot_drive(d, tmp_path / f"{d.label}.png")
        assert v.figures[d.label] == (tmp_path / f"{d.label}.png").read_bytes()


# ------------------------------------------------------------------ short logs
def test_piece_bounds_are_consecutive_whole_pieces_from_the_first_sample():
    from roadbank.validation.scoring import piece_bounds
    t = np.arange(0.0, 25.05, 0.1)                 # 25 s at 10 Hz: two whole 12 s pieces, the last 1 s left out
    assert piece_bounds(t, 12.0) == [(0, 120), (120, 240)]
    assert piece_bounds(t, 30.0) == []


def test_piece_bounds_across_a_gap_of_a_year_list_only_pieces_with_samples():
    """A drive whose time stamps jump by a year (a logger's clock; 3.15e7 s is a whole number of 8 s pieces): the
    pieces before and after the jump that hold samples (the one cut by the jump too, as any piece with a gap), none
    of the ~4 million empty ones between (scoring them raised "Signals: empty arrays")."""
    from roadbank.validation.scoring import piece_bounds
    t = np.concatenate([np.arange(300) * 0.1, 3.15e7 + np.arange(300) * 0.1])
    assert piece_bounds(t, 8.0) == [(0, 80), (80, 160), (160, 240), (240, 300), (300, 380), (380, 460), (460, 540)]


@needs_kitti
def test_the_short_log_scores_are_what_estimate_gives_on_each_piece_and_the_gyro_wins_there():
    """Drive 0070 cut into 8 s pieces: each piece's score is the CLI's estimator (vehicle.for_log on the piece as a
    log of its own) against the INS roll; the default, which takes the KITTI reader's roll rate even where the piece
    is too short for the check, is below the default without it (the ESP blend) and below kinematic-lp on most
    pieces."""
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.validation.kitti import KITTI_SCORING, short_log_scores
    from roadbank.validation.scoring import piece_bounds
    from roadbank.vehicle import for_log
    log = load_kitti_oxts(KITTI / "2011_09_26_drive_0070")
    names = ["kinematic-lp", "kinematic-pif", "kinematic-pif-esp"]
    got = short_log_scores(log, names, None, KITTI_SCORING)[8.0]
    bounds = [(a, b) for a, b in piece_bounds(log.signals.t, 8.0)
              if masks(log.signals.t[a:b], log.signals.vx[a:b], KITTI_SCORING)[1].any()]
    assert len(got["kinematic-pif"]) == len(bounds) >= 4
    for (a, b), rms in zip(bounds, got["kinematic-pif"]):
        piece = log.signals[a:b]
        m = masks(piece.t, piece.vx, KITTI_SCORING)[1]
        theta = for_log("kinematic-pif", piece).run(piece).theta
        assert rms == pytest.approx(np.degrees(np.sqrt(np.mean((theta[m] - log.reference_roll[a:b][m]) ** 2))),
                                    rel=1e-9)
    gyro, esp, lp = (np.array(got[n]) for n in names[1:] + names[:1])
    assert np.median(gyro) < np.median(esp) and np.mean(gyro < lp) >= 0.75


@needs_kitti
def test_the_short_log_section_reports_the_medians_of_the_drives_pieces():
    """validate_kitti with its sensitivity runs: the split's short-log medians are those of its drives' pieces, and
    the markdown table and the JSON give them."""
    from roadbank.validation.kitti import SHORT_NAMES, validate_kitti
    from roadbank.validation.kitti_report import short_log_lines, to_json
    v = validate_kitti([KITTI / "2011_09_26_drive_0070"], names=list(SHORT_NAMES))
    pieces = v.drives[0].data["pieces"][8.0]
    part = v.by_split["validation"]["short_logs"][8.0]
    assert part["pieces"] == len(pieces["kinematic-pif"]) >= 4
    for n in SHORT_NAMES:
        assert part["median_rms_raw_deg"][n] == pytest.approx(float(np.median(pieces[n])), rel=1e-12)
    row = next(line for line in "\n".join(short_log_lines(v, "##")).splitlines() if line.startswith("| validation 8 s"))
    assert f"| {part['pieces']} |" in row and f"{part['median_rms_raw_deg']['kinematic-pif']:.3f}" in row
    assert to_json(v)["splits"]["validation"]["short_logs"]["8"]["pieces"] == part["pieces"]


@needs_kitti
def test_a_repeated_estimators_option_scores_every_one_named():
    """`-e a -e b` scores both, as `-e a,b` does (it had kept the last alone, as click does with a single option)."""
    drive = str(next(KITTI.glob("*/oxts")).parent)
    runs = [CliRunner().invoke(main, ["validate", "kitti", drive, *opts, "--json", "--no-sensitivity"])
            for opts in (["-e", "kinematic", "-e", "kinematic-lp"], ["-e", "kinematic,kinematic-lp"])]
    for res in runs:
        assert res.exit_code == 0, res.output
    scores = [json.loads(res.stdout)["drives"] for res in runs]
    assert scores[0] == scores[1] and all(set(v) == {"kinematic", "kinematic-lp"} for v in scores[0].values())


@needs_kitti
def test_the_smooth_road_section_scores_each_drive_as_estimate_reads_it_quiet():
    """Drive 0070 as each smooth road (validation.roads.smooth_road): it reads quiet; each score is the CLI's
    estimator on that log (vehicle.for_log, no vehicle file) against the INS roll; the split's medians, the markdown
    and the JSON give them; the default without the roll rate beats the car's model of a car nobody described there
    (the sixty-second stage's finding on the training drives, here on a validation drive)."""
    from roadbank.io.kitti import load_kitti_oxts
    from roadbank.validation.kitti import KITTI_SCORING, SMOOTH_NAMES, validate_kitti
    from roadbank.validation.kitti_report import smooth_road_lines, to_json
    from roadbank.validation.roads import SMOOTH_ROADS, smooth_road
    from roadbank.vehicle import SensorSpec, for_log, is_quiet, log_conditions
    log = load_kitti_oxts(KITTI / "2011_09_26_drive_0070")
    v = validate_kitti([KITTI / "2011_09_26_drive_0070"], names=list(SMOOTH_NAMES))
    got = v.drives[0].data["smooth_roads"]
    m = masks(log.signals.t, log.signals.vx, KITTI_SCORING)[1]
    for form, (order, cutoff) in SMOOTH_ROADS.items():
        s = smooth_road(log.signals, order, cutoff, seed=0)
        c = log_conditions(s)
        assert is_quiet(SensorSpec(), c["log_rate"], c["log_ay_noise"], log_ay_floor=c["log_ay_floor"])
        theta = for_log("kinematic-pif", s).run(s).theta
        assert got[form]["kinematic-pif"] == pytest.approx(
            np.degrees(np.sqrt(np.mean((theta[m] - log.reference_roll[m]) ** 2))), rel=1e-9)
        assert got[form]["kinematic-pif-esp"] < got[form]["pif-adaptive"]
        part = v.by_split["validation"]["smooth_roads"][form]
        assert part["drives"] == 1 and part["median_rms_raw_deg"]["kinematic-lp"] == got[form]["kinematic-lp"]
        row = next(line for line in "\n".join(smooth_road_lines(v, "##")).splitlines()
                   if line.startswith(f"| validation, {form} |"))
        assert f"{got[form]['kinematic-pif-esp']:.3f}" in row
        assert to_json(v)["splits"]["validation"]["smooth_roads"][form]["drives"] == 1
