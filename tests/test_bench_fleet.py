"""The benchmark's fleet section runs ``run_fleet`` per format and worker count and reports what it
measured (no timing assertions: benchmarks are not tests)."""

from __future__ import annotations

import numpy as np
import pytest

from roadbank.bench import SECTIONS
from roadbank.bench.fleet import FLEET_SIZES, fleet_markdown, fleet_speed
from roadbank.fleet.bench import fleet_logs, write_fleet_log
from roadbank.io import load_log


def test_fleet_section_is_registered_and_quick_is_short():
    assert "fleet" in [s.name for s in SECTIONS]
    q = FLEET_SIZES["quick"]
    assert q["workers"] == (1, 2) and {"csv", "parquet"} <= set(q["formats"])
    assert q["logs"] * q["seconds"] * 100.0 <= 1.2e6                          # per format and worker count


def test_fleet_logs_are_the_same_drive_in_every_format_each_with_its_own_noise(tmp_path):
    csv, n = fleet_logs(tmp_path, 3, 12.0, "csv", bad_every=3)
    pq_, n2 = fleet_logs(tmp_path, 3, 12.0, "parquet", bad_every=3)
    assert n == n2 == 2 * 1200                                     # the third log is corrupt
    for a, b in zip(csv[:2], pq_[:2]):
        sa, sb = load_log(a).signals, load_log(b).signals
        np.testing.assert_array_equal(sa.ay, sb.ay)
        np.testing.assert_array_equal(sa.t, sb.t)
    assert write_fleet_log(tmp_path / "clean.csv", 12.0) == 1200
    clean = load_log(tmp_path / "clean.csv").signals.ay
    e0, e1 = (load_log(p).signals.ay - clean for p in csv[:2])
    assert np.std(e0) == pytest.approx(0.050, rel=0.06) and np.std(e1) == pytest.approx(0.051, rel=0.06)
    assert abs(np.corrcoef(e0, e1)[0, 1]) < 0.1                   # distinct draws


@pytest.mark.slow
def test_fleet_section_on_one_and_two_workers():
    out = fleet_speed({"size": "tiny"}, sizes={"logs": 4, "seconds": 5.0, "workers": (1, 2)})
    got = {(r["format"], r["workers"]) for r in out["rows"]}
    assert got == {("parquet", 1), ("parquet", 2), ("csv", 1), ("csv", 2)}
    for r in out["rows"]:
        assert r["failed"] == 0 and r["samples"] == 4 * 500 and r["samples_per_s"] > 0
        if r["workers"] == 1:
            assert r["speedup"] == 1.0 and r["startup_s"] == 0.0 and r["met"] is None
        else:
            assert r["startup_s"] > 0 and isinstance(r["met"], bool)
    text = "\n".join(fleet_markdown(out))
    assert "| csv | 2 |" in text and "| parquet | 1 |" in text and "design cache off" in text
