"""The fleet at scale of ``roadbank bench --fleet-logs N`` and the CPU time a fleet run reports
(no timing assertions: benchmarks are not tests)."""

from __future__ import annotations

import json
import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.fleet import run_fleet


def test_fleet_logs_option_reaches_the_fleet_section(monkeypatch):
    import roadbank.bench as bench
    seen = {}

    def fake_suite(size, progress=None, options=None):
        seen.update(size=size, options=options)
        return {"size": size}
    monkeypatch.setattr(bench, "run_suite", fake_suite)
    res = CliRunner().invoke(main, ["bench", "--tiny", "--json", "--fleet-logs", "7"])
    assert res.exit_code == 0, res.output
    assert seen == {"size": "tiny", "options": {"fleet_logs": 7}}
    assert json.loads(res.stdout) == {"size": "tiny"}
    CliRunner().invoke(main, ["bench", "--tiny", "--json"])
    assert seen["options"] is None                            # not run by default
    bad = CliRunner().invoke(main, ["bench", "--tiny", "--fleet-logs", "-1"])
    assert bad.exit_code == 2 and "--fleet-logs" in bad.output


def _log(path, k, noise):
    t = np.arange(k) * 0.01
    rng = np.random.default_rng(k)
    pq.write_table(pa.table({"t": t, "vx": np.full(k, 20.0), "ay": 0.3 + noise * rng.standard_normal(k),
                             "r": np.full(k, 0.015), "delta_f": np.zeros(k)}), path)


def test_run_fleet_in_process_reports_its_cpu_time(tmp_path):
    paths = []
    for i in range(3):
        paths.append(tmp_path / f"log{i}.parquet")
        _log(paths[-1], 3000, 0.05 + 0.02 * i)
    res = run_fleet(paths, tmp_path / "out", ["pif-modified"])
    assert not res.failed
    assert math.isfinite(res.cpu_s) and res.cpu_s > 0 and res.client_cpu_s == 0.0


@pytest.mark.slow
def test_fleet_at_scale_on_one_and_two_workers_leaves_nothing_behind(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    import tempfile

    from roadbank.bench.fleet import fleet_markdown, fleet_scale
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    sc = fleet_scale(3, seconds=5.0)
    assert [p for p in tmp_path.iterdir() if p.name.startswith("roadbank")] == []    # logs and outputs removed
    assert [r["workers"] for r in sc["rows"]] == [1, 2] and sc["logs"] == 3 and sc["write_s"] > 0
    for r in sc["rows"]:
        assert r["failed"] == 0 and r["samples"] == 3 * 500 and r["samples_per_s"] > 0
        assert math.isfinite(r["cpu_s"]) and r["cpu_s"] > 0 and r["cpu_ratio"] > 0
    one, two = sc["rows"]
    assert one["cpu_ratio"] == 1.0 and one["met"] is None and isinstance(two["met"], bool)
    assert two["startup_s"] > 0 and two["client_cpu_s"] > 0
    out = {"rows": [], "skipped": {}, "estimator": "pif-modified", "logs": 0, "seconds_per_log": 0.0,
           "target_speedup": 1.8, "cores": 2, "scale": sc}
    text = "\n".join(fleet_markdown(out))
    assert "--fleet-logs 3" in text and "| parquet | 2 |" in text and "CPU vs 1 worker" in text


def test_the_warm_up_reads_one_log_of_each_format_and_survives_a_bad_one(tmp_path, monkeypatch):
    from roadbank.fleet import run as fleet_run
    (tmp_path / "drive").mkdir()
    paths = [tmp_path / n for n in ("a.csv", "b.CSV", "c.parquet", "drive", "d.parquet")]
    assert fleet_run._first_of_each_format(paths) == [paths[0], paths[2], paths[3]]
    _log(tmp_path / "c.parquet", 2000, 0.1)
    (tmp_path / "a.csv").write_text("t,vx\n0,not a number\n")
    read = []
    real = fleet_run._read_first_chunk
    monkeypatch.setattr(fleet_run, "_read_first_chunk", lambda p, *a: read.append(p) or real(p, *a))
    assert fleet_run._warm(["pif-modified"], None, None, [tmp_path / "a.csv", tmp_path / "c.parquet"]) is True
    assert read == [tmp_path / "a.csv", tmp_path / "c.parquet"]


def test_an_unmet_fleet_target_is_explained_with_its_cpu_ratio():
    from roadbank.bench.report import obstacles
    from roadbank.bench.suite import TARGETS
    row = {"workers": 2, "speedup": 1.2, "cpu_ratio": 1.1, "met": False}
    res = {"targets": {k: True for k in TARGETS}, "estimators": [{"name": "pif-modified"}],
           "fleet": {"rows": [dict(row, workers=1, met=None), row], "scale": {"rows": [dict(row, speedup=1.5)]}}}
    text = "\n".join(obstacles(res))
    assert "**Fleet speed-up**" in text and "1.20x, 1.50x wall" in text and "1.10, 1.10" in text
    res["fleet"] = {"rows": [dict(row, met=True)]}
    assert "Fleet" not in "\n".join(obstacles(res))
