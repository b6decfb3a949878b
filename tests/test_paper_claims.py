"""The paper's claims (SPEC 7) asserted on a full reproduction run on our plant."""

import numpy as np
import pytest

from roadbank import estimators as E
from roadbank.evaluation import evaluate
from roadbank.report import claims
from roadbank.report.tables import lookup
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


def test_claim1_pif_has_no_steady_state_error_dfc_uio_do(study):
    """Beyond the kinematic estimate's (exact in a steady state but for the sensors), the PIF's steady error is at
    most 0.1 deg in every const-bank condition (measured 0.00-0.09); DFC's and UIO's are not (0.27-106 deg)."""
    c = claims.claim_steady_state(study.rows, names=("pif-paper",))
    assert c.holds, c.detail
    ss = {(c, n): v for (sc, c, n), v in lookup(study.rows, "theta", "steady_deg").items() if sc == "const-bank"}
    for cond in ("nominal", "cf120", "low-mu", "misaligned"):
        assert abs(ss[(cond, "pif-paper")] - ss[(cond, "kinematic")]) <= claims.STEADY_TOL_DEG, cond
    assert abs(ss[("cf120", "dfc")] - ss[("cf120", "kinematic")]) > 1.0        # grows with the Cf error


@pytest.mark.xfail(strict=True, reason=(
    "The PIO (original model, Table 4) has a steady error of its own on low friction: theta 2.06 deg against the "
    "kinematic estimate's -0.03 (docs/results.md); elsewhere at most 0.06 deg. Its model's steering term is wrong "
    "once the front tyres saturate; the modified-model PIO, which does not use the steering, has 0.17 there."))
def test_claim1_pio_has_no_steady_state_error(study):
    c = claims.claim_steady_state(study.rows, names=("pio-original",))
    assert c.holds, c.detail


@pytest.mark.parametrize("scenario", ["const-bank", "track-lane1"])
def test_claim1_dfc_uio_error_grows_with_cf(study, scenario):
    c = claims.claim_cf_growth(study.rows, scenario=scenario)
    assert c.holds, c.detail


@pytest.mark.parametrize("condition", ["low-mu", "cf120"])
def test_claim2_pif_best_on_const_bank_under_low_mu_and_cf(study, condition):
    c = claims.claim_pif_best(study.rows, conditions=(condition,))
    assert c.holds, c.detail


@pytest.mark.xfail(strict=True, reason=(
    "With the misaligned accelerometer (a bias of -0.32 deg that every estimator reads as bank) the PIO has theta "
    "RMS 0.26 deg against the PIF's 0.30: the PIO's own steady error (+0.05 deg beyond the kinematic estimate's) "
    "happens to cancel part of the misalignment's (docs/results.md)."))
def test_claim2_pif_best_on_const_bank_with_a_misaligned_accelerometer(study):
    c = claims.claim_pif_best(study.rows, conditions=("misaligned",))
    assert c.holds, c.detail


@pytest.mark.parametrize("scenario", ["s-curve", "track-lane-change"])
def test_claim3_pif_modified_robust_to_cf_original_not(study, scenario):
    """In the S-curve the original-model PIF has failed already with the right stiffness (bank RMS 67 deg at the
    tyre limit), so that, not a change with Cf, is what the claim rests on there; on the track lane change it
    degrades with Cf (+40 deg at cf50)."""
    c = claims.claim_pif_cf_robust(study.rows, scenario=scenario)
    assert c.holds, c.detail
    assert ("fails with the nominal stiffness" in c.detail) == (scenario == "s-curve"), c.detail


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
    nobody, n = sum(not c["meeting"] for c in aims["cells"]), len(aims["cells"])
    assert "estimators meeting both" in text
    assert (f"No causal estimator of this study meets both aims in {nobody} of {n} cells" if nobody else
            f"In each of the {n} cells at least one causal estimator of this study meets both aims.") in text
