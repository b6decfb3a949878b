"""The default's targets, judged in one place (roadbank.validation.targets, tuning.simulated.sim_targets,
campaign.report.default_target) and reported by `roadbank validate` and `roadbank bench`: verdicts on results built
with known numbers, then the reports on the real data."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from roadbank.campaign.report import default_target
from roadbank.estimators import DEFAULT
from roadbank.tuning.simulated import TARGET_CAR, TARGET_DRIVES, SimulatedScores, sim_targets
from roadbank.validation.targets import CAUSAL, comma_targets, kitti_targets

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
SETS = ("comma2k19-example", "kitti-oxts", "kitti-oxts-extra")
needs_data = pytest.mark.skipif(not all((DATA / d).is_dir() for d in SETS), reason=f"real data {SETS} absent at {DATA}")


def _score(rms_raw=1.0, r=0.9, rms=0.1, lag=0.0):
    return SimpleNamespace(rms_raw_deg=rms_raw, r=r, rms_deg=rms, best_lag_s=lag)


def _kitti(medians: dict, below: int, drives: int, every: bool = True, car_from: str = "fitted to the log"):
    """A KITTI validation result whose validation drives have ``medians`` (``every``: with every other causal
    estimator at 1 deg, those that need a steering angle NaN, as on KITTI) and on which the default is below the
    kinematic estimate on ``below`` of ``drives``, designed for a car ``car_from``."""
    ds = [SimpleNamespace(label=f"d{k}", scores={DEFAULT: _score(0.3), "kinematic": _score(0.2 if k >= below else 0.9)},
                          data={"design": {"car_from": car_from}}) for k in range(drives)]
    rest = {n: float("nan") if n in ("dfc", "uio", "pio-original", "pif-original", "kalman") else 1.0 for n in CAUSAL}
    part = {"drives": [d.label for d in ds], "median_rms_raw_deg": {**(rest if every else {}), **medians}}
    return SimpleNamespace(by_split={"validation": part}, drives=ds)


@pytest.mark.parametrize("medians, met, lowest", [
    ({DEFAULT: 0.30, "kinematic": 0.6, "kinematic-lp": 0.31}, True, "kinematic-lp 0.31000"),
    ({DEFAULT: 0.30, "kinematic": 0.6, "kinematic-ff": 0.29}, False, "kinematic-ff 0.29000"),
    # the offline smoothers and the estimators that need a steering angle (NaN on KITTI) do not count
    ({DEFAULT: 0.30, "kinematic": 0.6, "kinematic-smoother": 0.1, "dfc": float("nan")}, True, "kinematic 0.60000"),
])
def test_the_kitti_target_compares_the_default_with_every_causal_estimator(medians, met, lowest):
    lowest_causal, _ = kitti_targets(_kitti(medians, 8, 8))
    assert lowest_causal.met is met
    assert lowest_causal.measured == f"0.30000 deg; lowest other: {lowest}"


@pytest.mark.parametrize("below, drives, met", [(9, 10, True), (8, 10, False), (8, 8, True)])
def test_the_kitti_target_asks_the_default_below_the_kinematic_estimate_on_90_percent(below, drives, met):
    _, share = kitti_targets(_kitti({DEFAULT: 0.3, "kinematic": 0.6}, below, drives))
    assert share.met is met and share.measured.startswith(f"{below} of {drives} ")


def test_the_lowest_causal_target_needs_every_causal_estimator_and_says_how_the_drives_were_designed():
    only = kitti_targets(_kitti({DEFAULT: 0.30, "kinematic": 0.6}, 8, 8, every=False))
    assert [t.text for t in only] == ["below the raw kinematic estimate on >= 90 % of the drives"]
    described = kitti_targets(_kitti({DEFAULT: 0.30, "kinematic": 0.6}, 8, 8, car_from="vehicle file"))
    assert {t.data for t in described} == {"KITTI validation drives (8), car given"}
    plain = kitti_targets(_kitti({DEFAULT: 0.3}, 8, 8))
    assert {t.data for t in plain} == {"KITTI validation drives (8), no vehicle file"}


def test_no_kitti_target_without_validation_drives_or_the_default():
    assert kitti_targets(SimpleNamespace(by_split={}, drives=[])) == []
    assert kitti_targets(_kitti({"kinematic": 0.6}, 1, 1, every=False)) == []


@pytest.mark.parametrize("d, met", [
    (_score(r=0.95, rms_raw=0.4), (True, True, True)),          # r above the kinematic estimate's
    (_score(r=0.925, rms_raw=0.4), (True, True, True)),         # 0.92 accepted: the raw RMS falls
    (_score(r=0.925, rms_raw=2.5), (False, True, True)),        # ... but not where it does not
    (_score(r=0.91, rms_raw=0.4, rms=0.111, lag=0.3), (False, False, False)),
])
def test_the_comma2k19_targets(d, met):
    res = SimpleNamespace(scores={DEFAULT: d, "kinematic": _score(r=0.93, rms_raw=2.0, lag=0.12)})
    assert tuple(t.met for t in comma_targets(res)) == met


def test_the_simulated_targets_on_the_stated_set_and_pooled():
    rng = np.random.default_rng(0)
    cars = (TARGET_CAR, "sedan")
    own, other = rng.uniform(0.1, 0.4, TARGET_DRIVES), rng.uniform(0.2, 0.9, TARGET_DRIVES)
    scores = SimulatedScores((DEFAULT,), cars, TARGET_DRIVES, 0, {},
                             {(DEFAULT, "known", TARGET_CAR): own, (DEFAULT, "known", "sedan"): other})
    stated, pooled = sim_targets(scores)
    assert stated.measured == f"{np.median(own):.3f} / {np.percentile(own, 95):.3f} deg"
    assert stated.met is bool(np.median(own) <= 0.30 and np.percentile(own, 95) <= 0.65)
    both = np.concatenate([own, other])
    assert pooled.measured == f"{np.median(both):.3f} / {np.percentile(both, 95):.3f} deg"
    assert pooled.met is False                      # p95 of U(0.2, 0.9) draws is far above 0.65
    assert sim_targets(scores, name="kinematic-lp") == []
    # another seed is not the set the target was stated on: the pooled verdict only
    other = SimulatedScores((DEFAULT,), cars, TARGET_DRIVES, 1, {}, scores.errors)
    assert [t.measured for t in sim_targets(other)] == [pooled.measured]


def test_the_campaign_target_is_the_default_p95_of_its_scored_runs():
    rms = np.linspace(0.1, 1.2, 100)
    df = pd.DataFrame({"estimator": [DEFAULT] * 100 + ["kinematic"] * 2, "error": [""] * 99 + ["boom"] + [""] * 2,
                       "rms_deg": list(rms) + [9.0, 9.0], "standstill_s": 3.0, "offsets": True})
    t = default_target(df)
    assert t.measured == f"{np.percentile(rms[:99], 95):.3f} deg" and t.met is False
    assert t.data == "campaign (99 runs, standstill starts, offsets learnt online)"
    assert default_target(df.assign(standstill_s=0.0, offsets=False)).data == "campaign (99 runs)"
    assert default_target(df.assign(rms_deg=df["rms_deg"] / 2)).met is True
    assert default_target(df[df["estimator"] == "kinematic"]) is None


@needs_data
def test_validate_reports_the_targets_on_the_real_data(tmp_path):
    from click.testing import CliRunner

    from roadbank.cli import main

    out = tmp_path / "comma.md"
    res = CliRunner().invoke(main, ["validate", "comma2k19", str(DATA / "comma2k19-example"), "--no-sensitivity",
                                    "-e", f"kinematic,{DEFAULT}", "-o", str(out)])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert f"| data | target of the default ({DEFAULT}) | measured | met? |" in text
    assert "| comma2k19 segment | smoothed RMS <= 0.11 deg |" in text


@pytest.mark.slow
@needs_data
def test_the_benchmark_states_the_real_data_targets_as_validate_does():
    from roadbank.bench.accuracy import accuracy, accuracy_markdown
    from roadbank.estimators import NAMES, OFFLINE
    from roadbank.validation.comma2k19 import validate_comma2k19

    out = accuracy({"size": "quick", "data": str(DATA)})
    assert [n.split(":")[0] for n in out["notes"]] == ["simulated validation set", "campaign"]
    comma = [t for t in out["targets"] if t["data"] == "comma2k19 segment"]
    names = [n for n in NAMES if n not in OFFLINE]
    expect = comma_targets(validate_comma2k19(DATA / "comma2k19-example", names=names, sensitivity=False))
    assert [(t["measured"], t["met"]) for t in comma] == [(t.measured, t.met) for t in expect]
    # the default's two KITTI targets, and the first again for the default without the drives' roll rate
    assert sum(t["data"].startswith("KITTI validation drives") for t in out["targets"]) == 3
    assert "| KITTI validation drives (8), no vehicle file |" in "\n".join(accuracy_markdown(out))
    assert "tiny" in accuracy({"size": "tiny"})["reason"]
