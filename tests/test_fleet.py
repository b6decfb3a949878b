"""Fleets: 200 small logs (some corrupt) in one go, interrupted and resumed, and on a 2-worker Dask cluster.

Truth: each good log's result table (recomputed statistics must equal its summary
row), the list of corrupt files (each must be reported with its file and
reason, none may stop the others), and the set of logs (each processed exactly
once across an interruption and a resume).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.fleet import expand_logs, run_fleet
from roadbank.fleet.run import read_summary
from roadbank.io import LogError

N_LOGS = 200
EST = ("kinematic",)


def _table(n, bank, vx=20.0):
    t = np.arange(n) * 0.01
    ay = np.full(n, 9.81 * math.sin(bank))
    z = np.zeros(n)
    return {"t": t, "vx": np.full(n, vx), "ay": ay, "r": z, "delta_f": z}


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """200 logs in nested folders: Parquet and CSV, every 17th one corrupt in a different way."""
    d = tmp_path_factory.mktemp("fleet")
    bad = {}
    kinds = ["truncated", "text", "missing", "empty"]
    for i in range(N_LOGS):
        sub = d / f"car{i % 4}"
        sub.mkdir(exist_ok=True)
        cols = _table(150 + i, bank=0.002 * i)
        if i % 17 == 5:
            kind = kinds[len(bad) % len(kinds)]
            p = sub / f"log{i:03d}.parquet"
            if kind == "truncated":
                pq.write_table(pa.table(cols), p)
                p.write_bytes(p.read_bytes()[:300])
            elif kind == "text":
                p = p.with_suffix(".csv")
                lines = ["t,vx,ay,r,delta_f"] + [",".join(repr(float(cols[k][j])) for k in cols)
                                                 for j in range(len(cols["t"]))]
                lines[40] = lines[40].replace(lines[40].split(",")[2], "oops")
                p.write_text("\n".join(lines) + "\n")
            elif kind == "missing":
                del cols["r"]
                pq.write_table(pa.table(cols), p)
            else:
                p.write_bytes(b"")
            bad[p] = kind
        else:
            pq.write_table(pa.table(cols), sub / f"log{i:03d}.parquet")
    return d, bad


def _check_outputs(outdir, paths, bad):
    rows = read_summary(outdir)
    by_log = {}
    for r in rows:
        assert r["log"] not in by_log, f"{r['log']} summarised twice"
        by_log[r["log"]] = r
    assert set(by_log) == {str(p) for p in paths}
    for p in paths:
        r = by_log[str(p)]
        if p in bad:
            assert r["status"] == "error" and p.name in r["error"] and r["output"] == ""
            continue
        assert r["status"] == "ok", r
        tab = pq.read_table(r["output"])
        # log i is a straight road on a bank of 0.002 i rad, where the kinematic estimate is exact
        i = int(p.stem[3:])
        np.testing.assert_allclose(tab.column("kinematic.theta").to_numpy(), 0.002 * i, rtol=1e-9, atol=1e-12)
        pb = tab.column("kinematic.phi_b").to_numpy()[tab.column("kinematic.valid").to_numpy()]
        assert int(r["samples"]) == tab.num_rows
        assert float(r["valid_share"]) == pytest.approx(len(pb) / tab.num_rows, rel=1e-5)
        assert float(r["bank_mean_deg"]) == pytest.approx(np.degrees(pb.mean()), rel=1e-5, abs=1e-6)
        assert float(r["bank_max_deg"]) == pytest.approx(np.degrees(pb.max()), rel=1e-5, abs=1e-6)
        assert float(r["duration_s"]) == pytest.approx(tab.column("t").to_numpy()[-1], rel=1e-5)
    return by_log


@pytest.mark.slow
def test_200_logs_one_bad_never_stops_others_and_resume(fleet, tmp_path):
    d, bad = fleet
    paths = expand_logs([d])
    assert len(paths) == N_LOGS and len(bad) >= 10
    out = tmp_path / "out"
    seen = []

    def interrupt(s):
        seen.append(s.log)
        if len(seen) == 120:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_fleet(paths, out, EST, on_result=interrupt)
    assert len(read_summary(out)) == 120                      # every finished log is already on disk
    res = run_fleet(paths, out, EST, resume=True)
    ok_before = sum(1 for p in seen if Path(p) not in bad)
    assert len(res.skipped) == ok_before                       # finished logs are not redone
    assert len(res.summaries) == N_LOGS - ok_before            # the rest, and the failed ones again
    # the retried bad logs' rows replace the first run's: one row per log, its latest
    assert len(read_summary(out)) == N_LOGS
    _check_outputs(out, paths, bad)
    assert not list(out.glob("*.partial"))


@pytest.mark.slow
def test_cli_dask_scheduler_glob(fleet, tmp_path):
    """On a running Dask scheduler (in-process, 2 worker threads, so the suite pays no process start-up;
    ``--workers N`` starts a LocalCluster of processes the same way, timed in docs/io.md)."""
    distributed = pytest.importorskip("distributed")
    d, bad = fleet
    pattern = str(d / "car[01]" / "*")
    paths = expand_logs([pattern])
    out = tmp_path / "dask"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as cluster:
        res = CliRunner().invoke(main, ["estimate", pattern, "-e", "kinematic", "--scheduler",
                                        cluster.scheduler_address, "-o", str(out)])
    assert res.exit_code == 1                                   # some logs were corrupt
    assert "Traceback" not in res.output
    by_log = _check_outputs(out, paths, bad)
    assert sum(r["status"] == "ok" for r in by_log.values()) == len([p for p in paths if p not in bad])
    for p in (p for p in paths if p in bad):
        assert f"FAILED {p}" in res.output
    assert "bank mean" in res.output and "ERROR" in res.output   # the summary table
    again = CliRunner().invoke(main, ["estimate", pattern, "-e", "kinematic", "--resume", "-o", str(out)])
    assert f"{len(paths) - len([p for p in paths if p in bad])} log(s) already finished" in again.output


@pytest.mark.slow
def test_long_log_benchmark_measures_the_child_alone(tmp_path):
    # the benchmark's peak RSS is the fresh process's own, not the (large) parent's inherited through fork
    import numpy as np

    from roadbank.fleet.bench import measure, write_long_log

    log = tmp_path / "short.parquet"
    n = write_long_log(log, hours=0.05)                  # 3 min at 100 Hz
    ballast = np.ones(50_000_000)                         # ~400 MB in this (parent) process
    res = measure("stream", log, tmp_path / "out.parquet")
    assert res["samples"] == n and res["samples_per_s"] > 0
    assert 30 < res["peak_rss_mb"] < ballast.nbytes / 2**20
    # CPU of the run itself (one thread): more than nothing, not more than its wall time allows
    assert 0 < res["run_cpu_s"] <= 1.2 * res["run_s"] + 0.05
    assert res["samples_per_cpu_s"] == pytest.approx(n / res["run_cpu_s"])


def _write(p: Path, bank: float) -> Path:
    p.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.table(_table(300, bank)), p)
    return p


def _mean_theta(f) -> float:
    return float(np.mean(pq.read_table(f).column("kinematic.theta").to_numpy()))


def test_resume_keeps_each_logs_output_name_when_logs_are_added(tmp_path):
    """Two logs of one name, then a third of that name sorting first, added before a resume: the new log takes a name
    no log had, and the two results written before are untouched (the names followed the sorted list of logs, so the
    new log overwrote another's result, and summary.csv pointed two logs at one file)."""
    d, out = tmp_path / "logs", tmp_path / "out"
    b, c = _write(d / "b" / "same.parquet", 0.01), _write(d / "c" / "same.parquet", 0.02)
    run_fleet(expand_logs([d]), out, EST)
    first = {r["log"]: r["output"] for r in read_summary(out)}
    a = _write(d / "a" / "same.parquet", 0.03)
    res = run_fleet(expand_logs([d]), out, EST, resume=True)
    assert sorted(res.skipped) == sorted([str(b), str(c)]) and [s.log for s in res.summaries] == [str(a)]
    rows = {r["log"]: r["output"] for r in read_summary(out)}
    assert {k: rows[k] for k in first} == first and len(set(rows.values())) == 3
    for log, bank in ((b, 0.01), (c, 0.02), (a, 0.03)):
        assert _mean_theta(rows[str(log)]) == pytest.approx(bank, abs=1e-9)


def test_resume_with_other_settings_is_refused_and_the_same_ones_resume(tmp_path):
    """A resume with other estimators or another output format is refused naming what changed (it skipped every log
    and left tables of the first settings: no CSV written, no new estimator's columns); the same settings resume,
    a run without --resume starts again with the new ones."""
    d, out = tmp_path / "logs", tmp_path / "out"
    _write(d / "x.parquet", 0.01)
    run_fleet(expand_logs([d]), out, EST)
    with pytest.raises(LogError, match=r"its logs were estimated with other settings \(estimators: kinematic then, "
                                        r"pif-modified now\): --resume would mix them"):
        run_fleet(expand_logs([d]), out, ("pif-modified",), resume=True)
    with pytest.raises(LogError, match=r"output format: parquet then, csv now"):
        run_fleet(expand_logs([d]), out, EST, output_format="csv", resume=True)
    assert len(run_fleet(expand_logs([d]), out, EST, resume=True).skipped) == 1
    res = run_fleet(expand_logs([d]), out, ("pif-modified",))
    assert [s.status for s in res.summaries] == ["ok"]
    res = CliRunner().invoke(main, ["estimate", str(d), "-e", "kinematic", "-o", str(out), "--resume"])
    assert res.exit_code == 1 and "Traceback" not in res.output and "other settings" in res.output, res.output


def test_a_log_known_by_another_spelling_of_its_path_is_not_redone(tmp_path, monkeypatch):
    """Resuming with the logs given by absolute paths after relative ones: each log is known by what it reads, so
    nothing is estimated again and summary.csv keeps one row per log."""
    monkeypatch.chdir(tmp_path)
    _write(tmp_path / "logs" / "x.parquet", 0.01)
    run_fleet(expand_logs(["logs"]), tmp_path / "out", EST)
    res = run_fleet(expand_logs([str(tmp_path / "logs")]), tmp_path / "out", EST, resume=True)
    assert res.summaries == [] and len(res.skipped) == 1
    assert len(read_summary(tmp_path / "out")) == 1


def test_logs_with_names_too_long_for_an_output_name_are_written_apart(tmp_path):
    """Two logs of 240-character names that differ only at the end (and one with a 3-byte character there): each is
    written under a name cut to fit a file name with a digest that keeps them apart (the output's temporary name
    exceeded the 255 bytes a file name may have: '[Errno 36] File name too long', on every resume too)."""
    d = tmp_path / "logs"
    for stem in ("L" * 239 + "A", "L" * 239 + "B", "L" * 230 + "\u20ac" * 4):
        _write(d / f"{stem}.parquet", 0.01)
    res = run_fleet(expand_logs([d]), tmp_path / "out", EST)
    assert [s.status for s in res.summaries] == ["ok"] * 3, [s.error for s in res.summaries]
    names = [Path(s.output).name for s in res.summaries]
    assert len(set(names)) == 3 and all(len(n.encode()) + len(".partial") <= 255 for n in names)
    assert all(n.startswith("L" * 150) for n in names)
