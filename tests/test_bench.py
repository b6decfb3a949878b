"""The benchmark runner works on a tiny input (no timing assertions: benchmarks are not tests)."""

import json
import math

import pytest

from click.testing import CliRunner

from roadbank.cli import main
from roadbank.bench import (FAMILY_PROBES, TARGETS, Section, markdown, probe_family, register_section,
                            run_suite, synthetic_log)

REQUIRED = ("pif_ns_per_sample", "pif_vs_filterpy", "step_us_median", "step_us_p99",
            "plant_realtime_factor", "plant_vs_commonroad", "reproduce_s", "reproduce_cold_s",
            "cold_compile_max_s")


def _positive_or_explained(res, key):
    v = res[key]
    if v is None:
        assert isinstance(res["reasons"].get(key), str) and res["reasons"][key]
    else:
        assert isinstance(v, (int, float)) and math.isfinite(v) and v > 0, (key, v)


@pytest.mark.slow
def test_bench_cli_tiny_json_and_markdown(tmp_path):
    out = tmp_path / "bench.md"
    result = CliRunner().invoke(main, ["bench", "--tiny", "--json", "-o", str(out)])
    assert result.exit_code == 0, result.output
    res = json.loads(result.stdout)
    for key in REQUIRED:
        assert key in res
        _positive_or_explained(res, key)
    assert res["reproduce_s"] is None            # never run on a tiny input
    assert set(res["cold_compile_s"]) == set(FAMILY_PROBES)
    assert res["machine"]["cores_usable"] >= 1
    assert set(res["targets"]) == set(TARGETS)
    text = out.read_text()
    assert text.startswith("# Benchmarks")
    assert "roadbank bench" in text and "| what | value | peer | ratio | target | met? |" in text


@pytest.mark.slow
def test_suite_reports_every_estimator_and_rejects_no_numbers():
    res = run_suite("tiny")
    names = [e["name"] for e in res["estimators"]]
    assert "pif-modified" in names and "pif-modified (riccati)" in names
    for e in res["estimators"]:
        assert e["ns_per_sample"] > 0 and e["design_s"] >= 0
    assert "# Benchmarks" in markdown(res, "roadbank bench --tiny")


def test_synthetic_log_is_deterministic_and_covers_the_schedule():
    a, b = synthetic_log(20.0), synthetic_log(20.0)
    assert len(a) == 2001 and (a.vx == b.vx).all()
    assert synthetic_log(600.0).vx.min() < 10 and synthetic_log(600.0).vx.max() > 30


@pytest.fixture
def no_extra_sections():
    from roadbank.bench import suite
    saved = list(suite.SECTIONS)
    suite.SECTIONS[:] = []
    yield suite.SECTIONS
    suite.SECTIONS[:] = saved


@pytest.mark.slow
def test_extra_sections_are_run_reported_and_isolated(no_extra_sections):
    register_section(Section("c_step", "C step cost", lambda cfg: {"ns": 12.5, "size": cfg["size"]},
                             lambda out: [f"C step: {out['ns']} ns"]))
    register_section(Section("broken", "A failing section", lambda cfg: 1 / 0))
    assert [s.name for s in no_extra_sections] == ["c_step", "broken"]
    res = run_suite("tiny")
    assert res["c_step"] == {"ns": 12.5, "size": "tiny"}
    assert "ZeroDivisionError" in res["broken"]["reason"]
    text = markdown(res, "roadbank bench --tiny")
    assert "## C step cost" in text and "C step: 12.5 ns" in text and "## A failing section" in text


@pytest.mark.slow
def test_cold_compile_probe_of_one_family_in_a_fresh_process():
    out = probe_family("dfc")
    assert out["cold_compile_s"] > 0 and out["cpu_first_s"] > 0, out
    assert out["again_s"] < out["first_s"]      # the second call runs compiled code


@pytest.mark.slow
def test_builtin_sections_c_step_and_long_log_on_a_tiny_run():
    from roadbank.bench.sections import C_ESTIMATORS, c_step, c_step_markdown, long_log

    out = c_step({"size": "tiny", "repeats": 1})
    if "reason" in out:                     # only when the machine has no C compiler
        pytest.skip(out["reason"])
    assert [r["name"] for r in out["rows"]] == [n for n, _ in C_ESTIMATORS]
    for r in out["rows"]:
        assert r["c_ns"] > 0 and r["python_ns"] > 0
        assert r["python_over_c"] == pytest.approx(r["python_ns"] / r["c_ns"])
    assert "c_f32_ns" in out["rows"][0]
    assert "| `pif-modified` |" in "\n".join(c_step_markdown(out))
    assert "full suite only" in long_log({"size": "tiny"})["reason"]


def test_the_long_log_table_gives_the_csv_streamed_and_whole():
    """The long-log section's table has the CSV rows: the streamed peak beside the whole read's, as measured."""
    from roadbank.bench.sections import long_log_markdown

    out = {"hours": 24.0, "samples": 8640000, "peak_rss_mb": 262.0, "baseline_rss_mb": 199.0, "samples_per_s": 1.5e6,
           "estimator": "kinematic-pif", "met": {"peak_rss_mb": True, "samples_per_s": True},
           "csv": {"hours": 3.0, "file_mb": 73.2, "samples": 1080000, "stream_peak_rss_mb": 238.0,
                   "stream_run_s": 4.44, "whole_peak_rss_mb": 524.0, "whole_run_s": 2.98}}
    text = "\n".join(long_log_markdown(out))
    assert "| peak RSS, streamed 3 h CSV log (73 MiB, 1080000 lines) | 238 MiB |" in text
    assert "| the same CSV read whole (`load_log`, then one run) | 524 MiB |" in text
    assert "| its time streamed / read whole | 4.4 / 3.0 s |" in text
    del out["csv"]
    assert "CSV log (" not in "\n".join(long_log_markdown(out))


def test_bench_data_option_reaches_the_accuracy_section(tmp_path):
    # the folder given reaches the section's settings; one that does not exist is refused
    from roadbank.bench import SECTIONS

    original = next(sec for sec in SECTIONS if sec.name == "accuracy")
    seen = []
    register_section(Section("accuracy", original.title, lambda cfg: seen.append(cfg.get("data")) or {"reason": "-"}))
    try:
        result = CliRunner().invoke(main, ["bench", "--tiny", "--json", "--data", str(tmp_path)])
    finally:
        register_section(original)
    assert result.exit_code == 0, result.output
    assert seen == [str(tmp_path)]
    missing = CliRunner().invoke(main, ["bench", "--tiny", "--data", str(tmp_path / "nowhere")])
    assert missing.exit_code == 2 and "does not exist" in missing.output


def test_accuracy_section_on_a_folder_without_data_sets_notes_it(tmp_path):
    from roadbank.bench.accuracy import accuracy

    out = accuracy({"size": "quick", "data": str(tmp_path)})
    assert out["targets"] == []
    assert out["notes"][:2] == ["KITTI: no drive found", "comma2k19: no segment found"]


def test_accuracy_section_without_data_says_what_it_did_not_run():
    from roadbank.bench.accuracy import accuracy, accuracy_markdown

    out = accuracy({"size": "quick"})
    assert out["targets"] == [] and len(out["notes"]) == 3
    assert "--data DIR" in out["notes"][0] and all("full suite only" in n for n in out["notes"][1:])
    assert "Not timed." in "\n".join(accuracy_markdown(out))


@pytest.mark.slow
def test_a_users_first_estimate_compiles_then_loads_from_the_caches(tmp_path):
    """roadbank.bench.first_run: the plain command in a fresh process with empty caches, then again with them
    filled; the first compiles (the kernels its default runs), so it takes longer; a log the command refuses is a
    reason, not a crash; the table shows what was measured."""
    from roadbank.bench.first_run import SECTION, first_estimate, first_run, first_run_markdown
    from roadbank.fleet.bench import write_long_log

    log = tmp_path / "short.parquet"
    write_long_log(log, 20.0 / 3600.0)
    out = first_estimate(log)
    assert 0 < out["warm_s"] < out["cold_s"], out
    bad = tmp_path / "bad.csv"
    bad.write_text("t,vx\n0,1\n")
    refused = first_estimate(bad)
    assert refused["reason"].startswith("cold run failed") and "bad.csv" in refused["reason"]
    text = "\n".join(first_run_markdown({"cases": [{"case": "short", **out}, {"case": "bad", **refused}],
                                         "data": False}))
    assert f"| short | {out['cold_s']:.1f} | {out['warm_s']:.1f} | {out['cold_s'] - out['warm_s']:.1f} |" in text
    assert "| bad |" in text and "n/a: cold run failed" in text and "--data" in text
    assert "not run with --tiny" in first_run({"size": "tiny"})["reason"]
    assert SECTION.name == "first_run"


def test_cold_compile_keeps_the_median_run_of_each_family(monkeypatch):
    """Each family probed ``repeats`` times, the families in turn; the run kept is the median one (the lower middle
    of an even count), every run's time listed; a failed run stands for its family."""
    from roadbank.bench import cold

    times = {"a": iter([5.0, 3.0, 4.0]), "b": iter([1.0, 2.0, 9.0, 7.0]), "c": iter([1.0, None, 2.0])}
    order = []

    def fake(family):
        order.append(family)
        v = next(times[family])
        return {"cold_compile_s": v, "cpu_first_s": v} if v is not None else {"cold_compile_s": None, "reason": "x"}
    monkeypatch.setattr(cold, "probe_family", fake)
    out = cold.cold_compile(["a", "c"], repeats=3)
    assert order == ["a", "c"] * 3
    assert out["a"]["cold_compile_s"] == 4.0 and out["a"]["runs"] == [5.0, 3.0, 4.0]
    assert out["c"] == {"cold_compile_s": None, "reason": "x"}
    assert cold.cold_compile(["b"], repeats=4)["b"]["cold_compile_s"] == 2.0


def test_filterpy_ratio_is_the_median_of_rounds_paired_with_the_pif():
    pytest.importorskip("filterpy")
    from roadbank import estimators
    from roadbank.bench.suite import filterpy_peer
    log = synthetic_log(10.0)
    peer = filterpy_peer(log, 300, estimators.make("pif-modified"), rounds=3)
    assert len(peer["peer_rounds_ns"]) == 3 and len(peer["ratios"]) == 3
    assert peer["ratio"] == sorted(peer["ratios"])[1]
    assert peer["peer_ns_per_sample"] == sorted(peer["peer_rounds_ns"])[1]
    alone = filterpy_peer(log, 300)            # no estimator: the peer's time alone, no ratio
    assert "ratio" not in alone and alone["peer_ns_per_sample"] > 0
