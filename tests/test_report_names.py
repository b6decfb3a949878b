"""One name, one filter: ``pif-modified`` is roadbank's default tuning in every command, table and
column; the paper's Table 4 PIF is ``pif-paper`` (the one the paper's claims are checked on)."""

from __future__ import annotations

import numpy as np
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank import estimators
from roadbank.cli import main
from roadbank.estimators.pif import TUNINGS
from roadbank.evaluation.compare import usable_samples
from roadbank.evaluation.metrics import error_metrics
from roadbank.export.design import export_design
from roadbank.io.writers import estimate_table, write_table
from roadbank.sim import run_scenario


def test_pif_paper_is_the_modified_pif_with_table4_and_outside_names():
    paper, default = estimators.make("pif-paper"), estimators.make("pif-modified")
    assert paper.name == "pif-paper" and paper.model == "modified"
    assert (paper.Q, paper.S, paper.th) == (TUNINGS["paper"]["Q"], TUNINGS["paper"]["S"], TUNINGS["paper"]["th"])
    assert np.allclose(np.diag(paper.R), TUNINGS["paper"]["R"])
    assert default.name == "pif-modified" and default.Q != paper.Q
    # a preset of an estimator of NAMES, so the suites that try every estimator run it once
    assert "pif-paper" in estimators.PRESETS and "pif-paper" not in estimators.NAMES
    with pytest.raises(ValueError, match="pif-paper"):
        estimators.make("pif-nope")


def _rms_deg(name: str, sim) -> float:
    """Bank RMS (deg) after 2 s of ``estimators.make(name)`` on ``sim``: what the tables must say."""
    est = estimators.make(name)
    e = est.run(sim.signals)
    usable = usable_samples(sim.signals, est.v_min)
    return error_metrics(sim.signals.t, e.phi_b, sim.truth.phi_b, usable, settle=2.0).rms_deg


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    out = tmp_path_factory.mktemp("names")
    res = CliRunner().invoke(main, ["reproduce", "-o", str(out), "--scenarios", "const-bank", "-j", "1",
                                    "--estimators", "pif-paper,pif-modified,dfc"])
    assert res.exit_code == 0, res.output
    return out, res.output


def test_reproduce_columns_are_the_estimators_of_those_names(reproduced):
    out, output = reproduced
    rows = pacsv.read_csv(out / "metrics.csv").to_pylist()
    assert {r["estimator"] for r in pq.read_table(out / "metrics.parquet").to_pylist()} == \
        {"pif-paper", "pif-modified", "dfc"}
    rms = {(r["condition"], r["estimator"]): r["value"] for r in rows
           if r["reference"] == "bank" and r["metric"] == "rms_deg"}
    assert {n for _, n in rms} == {"pif-paper", "pif-modified", "dfc"}
    for cond in ("nominal", "low-mu"):
        sim = run_scenario("const-bank", cond)
        # pif-modified: what estimators.make("pif-modified") (= roadbank estimate -e pif-modified) gives
        assert rms[cond, "pif-modified"] == pytest.approx(_rms_deg("pif-modified", sim), abs=1e-9)
        # pif-paper: the PIF with Table 4 (not the default)
        table4 = estimators.make("pif-modified", tuning="paper")
        e = table4.run(sim.signals)
        want = error_metrics(sim.signals.t, e.phi_b, sim.truth.phi_b,
                             usable_samples(sim.signals, table4.v_min), settle=2.0).rms_deg
        assert rms[cond, "pif-paper"] == pytest.approx(want, abs=1e-9)
    # on low mu the two tunings differ clearly (Table 4 0.07 deg, the default 0.16 deg)
    assert abs(rms["low-mu", "pif-paper"] - rms["low-mu", "pif-modified"]) > 0.03
    # the tables and the terminal summary say which tuning each column is
    md = (out / "report.md").read_text()
    assert "`pif-paper`: the paper's Table 4 weights" in md
    assert md.count("Tuning: `pif-paper`") >= 7            # a legend under every metric table
    assert "| PIF, Table 4 | PIF, default tuning |" in md
    assert "pif-paper: the paper's Table 4 weights" in output


def test_old_name_pif_default_is_gone():
    res = CliRunner().invoke(main, ["reproduce", "-o", "/nonexistent/x", "--estimators", "pif-default"])
    assert res.exit_code == 2 and "pif-default" in res.output and "pif-paper" in res.output


def test_estimate_accepts_pif_paper_and_names_its_columns(tmp_path):
    log = tmp_path / "cb.parquet"
    res = CliRunner().invoke(main, ["simulate", "const-bank", "-c", "low-mu", "-o", str(log)])
    assert res.exit_code == 0, res.output
    out = tmp_path / "bank.parquet"
    res = CliRunner().invoke(main, ["estimate", str(log), "-e", "pif-paper,pif-modified", "--vehicle", "suv-paper",
                                    "-o", str(out)])          # the simulated car, described
    assert res.exit_code == 0, res.output
    table = pq.read_table(out)
    assert {"pif-paper.phi_b", "pif-modified.phi_b"} <= set(table.column_names)
    sim = run_scenario("const-bank", "low-mu")
    want = estimators.make("pif-paper").run(sim.signals).phi_b
    got = table.column("pif-paper.phi_b").to_numpy()
    assert np.allclose(got, want, atol=1e-9, equal_nan=True)
    assert not np.allclose(got, table.column("pif-modified.phi_b").to_numpy(), atol=1e-4, equal_nan=True)


def test_a_named_tuning_other_than_its_own_is_in_the_name(tmp_path):
    """``make("pif-modified", tuning="paper-deg")`` was named ``pif-modified``: written next to the default its
    columns took the default's names and one of the two estimates was lost."""
    default, deg = estimators.make("pif-modified"), estimators.make("pif-modified", tuning="paper-deg")
    assert (default.name, deg.name) == ("pif-modified", "pif-modified[paper-deg]")
    assert deg.R[0, 0] == TUNINGS["paper-deg"]["R"]                       # the filter is the tuning asked for
    assert estimators.make("pif-original", tuning="paper-deg").name == "pif-original[paper-deg]"
    assert estimators.make("pif-gated", tuning="paper").name == "pif-gated[paper]"
    # its own tuning named, or none, leaves the name alone
    assert estimators.make("pif-modified", tuning="default").name == "pif-modified"
    assert estimators.make("pif-original", tuning="paper").name == "pif-original"
    assert estimators.make("pif-paper", tuning="paper").name == "pif-paper"
    # both estimates keep their own columns in one table, each holding its own estimate
    sim = run_scenario("const-bank", "low-mu")
    runs = [e.run(sim.signals) for e in (default, deg)]
    cols = pacsv.read_csv(write_table(tmp_path / "bank.csv", estimate_table(sim.signals.t, runs)))
    for e in runs:
        got = cols.column(f"{e.name}.phi_b").to_numpy(zero_copy_only=False)
        assert np.allclose(got, e.phi_b, atol=1e-9, equal_nan=True)
    assert not np.allclose(runs[0].phi_b, runs[1].phi_b, atol=1e-4, equal_nan=True)
    # a C export of it gets an identifier from the name
    assert export_design(deg, 100.0).ident == "pif_modified_paper_deg"
