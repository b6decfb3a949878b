"""``roadbank estimate``: outputs, batch processing with a bad file, exit codes."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from click.testing import CliRunner

from roadbank.cli import main


def _sim_table(n=400, bank=0.05):
    t = np.arange(n) * 0.01
    vx = np.full(n, 20.0)
    ay = np.full(n, 9.81 * np.sin(bank))   # straight, banked road: ay = g sin(theta)
    z = np.zeros(n)
    return {"t": t, "vx": vx, "ay": ay, "r": z, "delta_f": z, "steering_wheel_angle": z}


def test_estimate_single_csv_and_plot(tmp_path):
    p = tmp_path / "a.parquet"
    pq.write_table(pa.table(_sim_table()), p)
    out, png = tmp_path / "o.csv", tmp_path / "o.png"
    res = CliRunner().invoke(main, ["estimate", str(p), "-e", "kinematic", "-o", str(out), "--plot", str(png)])
    assert res.exit_code == 0, res.output
    header = out.read_text().splitlines()[0].split(",")
    assert header == ["t", "kinematic.theta", "kinematic.phi_b", "kinematic.valid", "kinematic.settled"]
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    # kinematic: w = (ay - vx r)/g = sin(0.05) -> theta = 0.05 rad
    np.testing.assert_allclose(data[:, 1], 0.05, atol=1e-9)
    assert png.stat().st_size > 1000


def test_batch_bad_file_reported_and_others_written(tmp_path):
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("a", "b"):
        pq.write_table(pa.table(_sim_table()), logs / f"{name}.parquet")
    (logs / "broken.parquet").write_bytes(b"PAR1 not really")
    outdir = tmp_path / "out"
    res = CliRunner().invoke(main, ["estimate", *sorted(map(str, logs.iterdir())), "-e", "kinematic,dfc",
                                    "-o", str(outdir) + "/", "--output-format", "parquet"])
    assert res.exit_code == 1
    assert "broken.parquet" in res.output and "not a readable Parquet file" in res.output
    assert "Traceback" not in res.output
    # the results of the good logs, and the summary table (one row per log, the bad one with its error)
    assert sorted(p.name for p in outdir.iterdir()) == ["a.bank.parquet", "b.bank.parquet", "settings.json",
                                                        "summary.csv"]
    rows = {Path(r["log"]).name: r for r in csv.DictReader(open(outdir / "summary.csv"))}
    assert rows["broken.parquet"]["status"] == "error" and "not a readable Parquet" in rows["broken.parquet"]["error"]
    assert rows["a.parquet"]["status"] == "ok" and rows["a.parquet"]["estimator"] == "kinematic"
    cols = pq.read_table(outdir / "a.bank.parquet").column_names
    assert cols == ["t", "kinematic.theta", "kinematic.phi_b", "kinematic.valid", "kinematic.settled",
                    "dfc.theta", "dfc.phi_b", "dfc.valid", "dfc.settled"]


def test_batch_all_good_exit_zero(tmp_path):
    p = tmp_path / "a.csv"
    cols = _sim_table(100)
    np.savetxt(p, np.column_stack(list(cols.values())), delimiter=",", header=",".join(cols), comments="")
    res = CliRunner().invoke(main, ["estimate", str(p), str(p), "-e", "kinematic", "-o", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output


def test_unknown_estimator_is_usage_error(tmp_path):
    res = CliRunner().invoke(main, ["estimate", "x.csv", "-e", "nope", "-o", str(tmp_path / "o.csv")])
    assert res.exit_code == 2 and "unknown estimator" in res.output


def test_the_summary_tells_logs_of_one_name_apart_and_keeps_its_columns(tmp_path):
    """Two logs named ``log.parquet`` in two folders (one day's and another's) with the longest-named estimators:
    the table and the design lines name each by as many folders as tell them apart (before: both ``log.parquet``),
    and every row's columns line up with the header's (before: ``kinematic-smoother`` pushed its row one column
    right)."""
    from roadbank.cli.estimate import log_names

    assert log_names(["/x/day1/log.csv", "/x/day2/log.csv", "/y/a.csv", "/z/day1/log.csv"]) == [
        "x/day1/log.csv", "day2/log.csv", "a.csv", "z/day1/log.csv"]
    assert log_names(["/a.csv", "/a.csv"]) == ["/a.csv", "/a.csv"]       # the same file twice: nothing tells
    logs = []
    for day in ("day1", "day2"):
        (tmp_path / day).mkdir()
        logs.append(tmp_path / day / "log.parquet")
        pq.write_table(pa.table(_sim_table(2000)), logs[-1])
    res = CliRunner().invoke(main, ["estimate", *map(str, logs), "-e", "kinematic,kinematic-smoother",
                                    "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    head = next(i for i, x in enumerate(lines) if x.startswith("log "))
    rows = lines[head + 2:head + 6]
    assert [r.split()[0] for r in rows[::2]] == ["day1/log.parquet", "day2/log.parquet"], rows
    end = lines[head].index("duration") + len("duration") - 1
    for r in rows:          # the duration ends under the header's "duration", "valid" under "valid"
        assert r[end] == "s" and r[end + 1] == " ", (lines[head], r)
        assert r[:lines[head].index("valid") + 5].endswith("%"), (lines[head], r)
    assert sum(x.startswith("designed for day1/log.parquet") for x in lines) == 1
    assert sum(x.startswith("designed for day2/log.parquet") for x in lines) == 1
