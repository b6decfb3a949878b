"""The paper's claims (SPEC 7) asserted on a full reproduction run on our plant."""

import numpy as np
import pytest

from roadbank import estimators as E
from roadbank.evaluation import evaluate
from roadbank.report import claims
from roadbank.report.reproduce import run_study, write_outputs
from roadbank.sim import CONDITIONS_BY_SCENARIO, run_scenario


@pytest.fixture(scope="module")
def study():
    return run_study(jobs=2)


def test_study_checks_the_paper_with_table4():
    """The claims are checked on the PIF as published (Table 4, ``pif-paper``), not on roadbank's
    default (``pif-modified``): the study has both columns, each the estimator of that name."""
    from roadbank.estimators.pif import TUNINGS
    from roadbank.report.reproduce import COLUMNS
    assert {"pif-paper", "pif-modified"} <= set(COLUMNS)
    paper = E.make("pif-paper")
    assert (paper.name, paper.Q, paper.th) == ("pif-paper", TUNINGS["paper"]["Q"], TUNINGS["paper"]["th"])
    assert E.make("pif-modified").Q != paper.Q


def test_study_covers_every_cell_and_estimator(study):
    assert len(study.cells) == sum(len(v) for v in CONDITIONS_BY_SCENARIO.values())
    for r in study.rows:
        if r["metric"] != "t_conv_s":
            assert np.isfinite(r["value"]), r


def test_claim1_pif_pio_no_steady_state_error_dfc_uio_do(study):
    c = claims.claim_steady_state(study.rows)
    assert c.holds, c.detail


@pytest.mark.parametrize("scenario", ["const-bank", "track-lane1"])
def test_claim1_dfc_uio_error_grows_with_cf(study, scenario):
    c = claims.claim_cf_growth(study.rows, scenario=scenario)
    assert c.holds, c.detail


def test_claim2_pif_best_on_const_bank_under_low_mu_misalignment_cf(study):
    c = claims.claim_pif_best(study.rows)
    assert c.holds, c.detail


@pytest.mark.parametrize("scenario", ["s-curve", "track-lane-change"])
def test_claim3_pif_modified_robust_to_cf_original_not(study, scenario):
    c = claims.claim_pif_cf_robust(study.rows, scenario=scenario)
    assert c.holds, c.detail


@pytest.mark.xfail(strict=True, reason=(
    "With Table 4 read in SI units (R = 0.0035 (rad/s)^2) the PIF lags the abrupt 14 deg bank "
    "steps of the lane change (bank RMS ~2.0 deg) while the UIO tracks them (0.54 deg); see "
    "test_claim2_bank_lane_change_with_R_in_deg_units and docs/results.md"))
def test_claim2_bank_lane_change_table4_si(study):
    c = claims.claim_pif_best(study.rows, scenario="bank-lane-change")
    assert c.holds, c.detail


def test_claim2_bank_lane_change_with_R_in_deg_units():
    """Reading Table 4's R in the ESP sensor's unit (deg/s)^2 makes the claim hold."""
    rows = []
    for cond in CONDITIONS_BY_SCENARIO["bank-lane-change"]:
        sim = run_scenario("bank-lane-change", cond)
        rows += evaluate(sim, ("pif-paper", "pio-original", "dfc", "uio"),
                         tuning={"pif-paper": {"tuning": "paper-deg"}}).rows
    c = claims.claim_pif_best(rows, scenario="bank-lane-change")
    assert c.holds, c.detail


@pytest.mark.slow
def test_outputs_written(study, tmp_path):
    written = write_outputs(study, tmp_path, docs_results=tmp_path / "docs" / "results.md")
    for p in written["tables"] + written["report"]:
        assert p.exists() and p.stat().st_size > 0
    text = (tmp_path / "report.md").read_text()
    assert "The paper's claims" in text and "![const-bank]" in text
    import pyarrow.parquet as pq
    t = pq.read_table(tmp_path / "metrics.parquet")
    assert t.column_names == ["scenario", "condition", "estimator", "reference", "metric", "value"]
    assert t.num_rows == len(study.rows)
    for key in ("s-curve-cf-robustness", "track-lane-change-cf-robustness", "const-bank"):
        assert all(p.exists() for p in written["figures"][key])


def test_accuracy_aims_say_which_estimators_meet_both_aims_in_each_cell(study):
    rms, mx = {}, {}
    for r in study.rows:
        if r["reference"] == "bank" and r["metric"] in ("rms_deg", "max_deg"):
            (rms if r["metric"] == "rms_deg" else mx)[r["scenario"], r["condition"], r["estimator"]] = r["value"]
    aims = claims.accuracy_aims(study.rows)
    assert len(aims["cells"]) == len(study.cells)
    for c in aims["cells"]:
        want = sorted(n for (s, cond, n), v in rms.items()
                      if (s, cond) == (c["scenario"], c["condition"]) and v <= 0.5 and mx[s, cond, n] <= 1.5)
        assert sorted(c["meeting"] + c["offline_meeting"]) == want
        assert not set(c["offline_meeting"]) - set(E.OFFLINE) and not set(c["meeting"]) & set(E.OFFLINE)
        assert (aims["estimator"] in c["meeting"]) == (c["rms_ok"] and c["max_ok"])
        causal = [v for (s, cond, n), v in rms.items() if (s, cond) == (c["scenario"], c["condition"])
                  and n not in E.OFFLINE]
        assert c["best_deg"] == min(causal)
    from roadbank.report.document import _aims_block
    text = "\n".join(_aims_block(study.rows, None))
    assert "estimators meeting both" in text and "No causal estimator of this study meets both aims in" in text
