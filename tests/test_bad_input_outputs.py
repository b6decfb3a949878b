"""Bad outputs and batch inputs (REPORT rows 4, 6, 7, 9 ENOSPC, 12 and the ``-o x.csv`` note): a one-line error
naming the path and the reason, or a flagged/warned result; never a traceback, never a good log lost."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.fleet import estimate_log
from roadbank.io.writers import WriteError
from roadbank.mapping import BankMap, LocalProjection


def _csv(path: Path, n: int = 300, vx: float = 20.0) -> Path:
    """A short log in roadbank's own columns: straight road banked 0.03 rad, 100 Hz."""
    t = np.arange(n) * 0.01
    ay = 9.81 * np.sin(0.03) + 0.02 * np.sin(7 * t)
    rows = "\n".join(f"{a:.2f},{vx:g},{b:.6f},0" for a, b in zip(t, ay))
    path.write_text("t,vx,ay,r\n" + rows + "\n")
    return path


def _drive(root: Path, name: str, n: int = 300) -> Path:
    """A KITTI-layout drive ``root/name/oxts`` (as tests/test_io_kitti.py makes them): n frames at 10 Hz,
    driving north at 15 m/s with ay 0.3 m/s^2. Returns the drive folder."""
    oxts = root / name / "oxts"
    (oxts / "data").mkdir(parents=True)
    stamps = [f"2011-01-01 12:{k // 600:02d}:{(k // 10) % 60:02d}.{(k % 10) * 100_000_000:09d}" for k in range(n)]
    (oxts / "timestamps.txt").write_text("\n".join(stamps) + "\n")
    for k in range(n):
        v = np.zeros(30)
        v[0], v[1], v[3], v[8], v[12] = 49.0 + k * 1.5 / 111_000, 8.4, 0.03, 15.0, 0.3 + 0.01 * np.sin(k)
        (oxts / "data" / f"{k:010d}.txt").write_text(" ".join(f"{x:.9f}" for x in v) + "\n")
    (oxts / "dataformat.txt").write_text("lat: latitude of the oxts-unit (deg)\n")
    return oxts.parent


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)      # the paths in the messages are the ones typed, relative


def _run(args, cwd: Path):
    """``roadbank ARGS`` run in ``cwd`` (the test's tmp_path); never a traceback."""
    assert Path.cwd() == cwd
    res = CliRunner().invoke(main, [str(a) for a in args])
    assert "Traceback" not in res.output, res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    return res


# ------------------------------------------------------------------ row 4: outputs that cannot be created
@pytest.mark.parametrize("args, message", [
    (["estimate", "a.csv", "-o", "b.csv/out.csv"],
     "error: -o: cannot write 'b.csv/out.csv': 'b.csv' is a file, not a directory"),
    (["estimate", "a.csv", "b.csv", "-o", "b.csv/outdir/"],
     "error: -o: cannot create directory 'b.csv/outdir': 'b.csv' is a file, not a directory"),
    (["estimate", "a.csv", "-o", "o.csv", "--plot", "b.csv/p.png"],
     "error: --plot: cannot write 'b.csv/p.png': 'b.csv' is a file, not a directory"),
    (["estimate", "a.csv", "b.csv", "-o", "out/", "--plot", "b.csv/plots"],
     "error: --plot: cannot create directory 'b.csv/plots': 'b.csv' is a file, not a directory"),
    (["estimate", "a.csv", "-o", "o_pd.csv"],
     "error: -o: cannot write 'o_pd.csv': its temporary file 'o_pd.csv.partial' is a directory"),
    (["map", "drive", "-o", "b.csv/m.parquet"],
     "error: -o: cannot write 'b.csv/m.parquet': 'b.csv' is a file, not a directory"),
    (["map", "drive", "-o", "m.parquet", "--png", "b.csv/m.png"],
     "error: --png: cannot write 'b.csv/m.png': 'b.csv' is a file, not a directory"),
    (["map", "drive", "-o", "m.parquet", "--geojson", "m.parquet.d"],
     "error: --geojson: cannot write 'm.parquet.d': it is a directory"),
], ids=["estimate-file", "estimate-dir", "plot-file", "plot-dir", "partial-is-dir", "map-file", "map-png",
        "map-geojson"])
def test_output_that_cannot_be_created_is_one_line_before_the_work(tmp_path, args, message):
    _csv(tmp_path / "a.csv")
    _csv(tmp_path / "b.csv")
    (tmp_path / "o_pd.csv.partial").mkdir()
    (tmp_path / "m.parquet.d").mkdir()
    (tmp_path / "drive").mkdir()        # never read: the output is checked first
    res = _run(args, tmp_path)
    assert res.exit_code == 1, res.output
    assert message in res.output
    assert "designed for" not in res.output and "mapping" not in res.output      # no work was done
    assert not (tmp_path / "o.csv").exists() and not (tmp_path / "m.parquet").exists()


def test_writer_error_names_the_output_and_is_not_hidden(tmp_path):
    """Through the API (no pre-check): the table's error names the path; removing the partial file does not
    raise over it."""
    log = _csv(tmp_path / "a.csv")
    Path("x.csv.partial").mkdir()
    for out, why in (("a.csv/o.csv", "'a.csv' is a file, not a directory"), ("x.csv", "its temporary file")):
        s = estimate_log(log, out, ["kinematic"])
        assert s.status == "error" and f"cannot write '{out}'" in s.error and why in s.error, s.error


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
def test_full_disk_names_the_output_path(tmp_path):
    """Row 9: ENOSPC (the partial file is /dev/full): FAILED names the output path, the good log is written."""
    _csv(tmp_path / "a.csv")
    _csv(tmp_path / "b.csv")
    (tmp_path / "full.csv.partial").symlink_to("/dev/full")
    res = _run(["estimate", "a.csv", "-e", "kinematic", "-o", "full.csv"], tmp_path)
    assert res.exit_code == 1
    assert "FAILED a.csv: cannot write 'full.csv': No space left on device" in res.output
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "a.bank.csv.partial").symlink_to("/dev/full")
    res = _run(["estimate", "a.csv", "b.csv", "-e", "kinematic", "-o", "out/", "--output-format", "csv"], tmp_path)
    assert res.exit_code == 1 and "1 log(s) written, 1 failed" in res.output
    assert "FAILED a.csv: cannot write 'out/a.bank.csv': No space left on device" in res.output
    assert (tmp_path / "out" / "b.bank.csv").is_file()


def test_plot_that_cannot_be_drawn_is_not_a_failed_log(tmp_path):
    _csv(tmp_path / "a.csv")
    res = _run(["estimate", "a.csv", "-e", "kinematic", "-o", "o.csv", "--plot", "p.xyz"], tmp_path)
    assert res.exit_code == 1
    assert "FAILED" not in res.output and "1 log(s) written, 0 failed, 1 plot(s) not written" in res.output
    assert "warning: plot not written: cannot write 'p.xyz'" in res.output and "the table o.csv was written" \
        in res.output
    assert (tmp_path / "o.csv").is_file()


def test_map_figure_of_another_format_is_refused_before_the_work(tmp_path):
    """--png m.xyz: refused before any log is read, nothing written (before: the map table was written, then the
    figure failed, saying what had been written; a failure after the work still says so,
    test_bank_map_files_that_cannot_be_written_name_the_path)."""
    _drive(tmp_path, "k1")
    res = _run(["map", "k1", "-o", "m.parquet", "--png", "m.xyz"], tmp_path)
    assert res.exit_code == 2 and "'m.xyz' must end in .png" in res.output, res.output
    assert not (tmp_path / "m.parquet").exists()


def test_bank_map_files_that_cannot_be_written_name_the_path(tmp_path):
    """Through the API (no pre-check): a WriteError naming the path and why, not the raw OSError."""
    bmap = BankMap(LocalProjection(48.0, 11.0), sectors=1)
    bmap.add(48.0 + np.arange(50) * 1e-5, np.full(50, 11.0), np.full(50, 0.03), np.ones(50, bool))
    Path("f.txt").write_text("a file")
    for write, out in ((bmap.write_geojson, "f.txt/m.geojson"), (bmap.plot, "f.txt/sub/m.png")):
        with pytest.raises(WriteError) as err:
            write(out)
        assert str(err.value) == f"cannot write '{out}': 'f.txt' is a file, not a directory"
    assert bmap.write_geojson("ok/m.geojson").is_file() and bmap.plot("ok/m.png").is_file()


# ------------------------------------------------------------------ the note: -o x.csv with several logs
def test_several_logs_into_a_file_name_is_a_usage_error(tmp_path):
    _csv(tmp_path / "a.csv")
    _csv(tmp_path / "b.csv")
    res = _run(["estimate", "a.csv", "b.csv", "-o", "x.csv"], tmp_path)
    assert res.exit_code == 2 and "'x.csv' names a file, but 2 logs are written" in res.output
    assert "give a directory, e.g. 'x/'" in res.output and not (tmp_path / "x.csv").exists()
    res = _run(["estimate", "a.csv", "b.csv", "-e", "kinematic", "-o", "x.csv/"], tmp_path)    # asked for
    assert res.exit_code == 0 and (tmp_path / "x.csv" / "a.bank.parquet").is_file()


# ------------------------------------------------------------------ row 6: --resume with a damaged summary.csv
def test_resume_with_a_binary_summary_is_one_line_naming_it(tmp_path):
    _csv(tmp_path / "a.csv")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "summary.csv").write_bytes(bytes(range(200, 256)) * 4)
    res = _run(["estimate", "a.csv", "-o", "out/", "--resume"], tmp_path)
    assert res.exit_code == 1
    assert "error: out/summary.csv: not a readable summary (not UTF-8 text: byte 0xc8 at position 0)" in res.output


def test_resume_drops_a_cut_last_row_and_starts_new_rows_on_a_new_line(tmp_path):
    for name in ("a", "b", "c"):
        _csv(tmp_path / f"{name}.csv")
    (tmp_path / "empty.csv").write_text("")
    logs = ["a.csv", "b.csv", "c.csv", "empty.csv"]
    res = _run(["estimate", *logs, "-e", "kinematic", "-o", "out/"], tmp_path)
    assert res.exit_code == 1
    summary = tmp_path / "out" / "summary.csv"
    lines = summary.read_bytes().split(b"\r\n")
    rows = [x for x in lines[1:] if x and not x.startswith(b"c.csv")]
    cut = next(x for x in lines if x.startswith(b"c.csv"))
    summary.write_bytes(b"\r\n".join([lines[0], *rows]) + b"\r\n" + cut[:40])     # the run died mid-row
    res = _run(["estimate", *logs, "-e", "kinematic", "-o", "out/", "--resume"], tmp_path)
    assert res.exit_code == 1, res.output
    assert "out/summary.csv: its last row was cut off" in res.output
    assert "2 log(s) already finished (--resume), skipped" in res.output          # a and b, not c
    with open(summary, newline="") as fh:
        table = list(csv.DictReader(fh))
    assert all(len(r) == len(table[0]) and None not in r for r in table)        # every row whole
    assert [r["log"] for r in table] == ["a.csv", "b.csv", "empty.csv", "c.csv"]     # one row per log, its latest
    assert table[3]["status"] == "ok" and table[2]["status"] == "error" and "file is empty" in table[2]["error"]


# ------------------------------------------------------------------ row 7: broken KITTI drives in a fleet
def _broken(root: Path, name: str, lacking: str) -> Path:
    """A drive whose oxts/ lacks ``lacking`` (timestamps.txt or data)."""
    d = _drive(root, name, n=4)
    target = d / "oxts" / lacking
    target.unlink() if target.is_file() else shutil.rmtree(target)
    return d


def test_broken_kitti_drives_in_a_fleet_are_failed_not_skipped(tmp_path):
    fleet = tmp_path / "fleet" / "b"
    _drive(fleet, "k_good", n=40)
    _broken(fleet, "k_ts_missing", "timestamps.txt")
    _broken(fleet, "k_no_data", "data")
    res = _run(["estimate", "fleet", "-e", "kinematic", "-o", "out/"], tmp_path)
    assert res.exit_code == 1
    why = "not a KITTI raw drive (no oxts/timestamps.txt and oxts/data/)"
    assert f"FAILED fleet/b/k_ts_missing: {why}: oxts/timestamps.txt missing" in res.output
    assert f"FAILED fleet/b/k_no_data: {why}: oxts/data/ missing" in res.output
    assert "1 log(s) written, 2 failed" in res.output
    assert (tmp_path / "out" / "k_good.bank.parquet").is_file()
    with open(tmp_path / "out" / "summary.csv", newline="") as fh:
        assert sorted(Path(r["log"]).name for r in csv.DictReader(fh)) == ["k_good", "k_no_data", "k_ts_missing"]


@pytest.mark.parametrize("fmt", [[], ["--format", "kitti-oxts"]], ids=["detected", "kitti-oxts"])
def test_one_broken_drive_gets_the_reason(tmp_path, fmt):
    _broken(tmp_path, "k_ts_missing", "timestamps.txt")
    res = _run(["estimate", "k_ts_missing", "-o", "o.csv", *fmt], tmp_path)
    assert res.exit_code == 1 and "no logs found" not in res.output
    assert "FAILED k_ts_missing: not a KITTI raw drive (no oxts/timestamps.txt and oxts/data/): " \
           "oxts/timestamps.txt missing" in res.output


def test_one_drive_in_a_folder_is_named_after_the_drive(tmp_path):
    _drive(tmp_path / "fleet" / "b", "k_good", n=40)
    res = _run(["estimate", "fleet", "-e", "kinematic", "-o", "out/"], tmp_path)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["k_good.bank.parquet", "settings.json",
                                                                    "summary.csv"]
    res = _run(["estimate", "fleet/b", "-e", "kinematic", "-o", "one.csv"], tmp_path)    # still one log, one file
    assert res.exit_code == 0 and (tmp_path / "one.csv").is_file()


def test_map_reports_a_broken_drive(tmp_path):
    _drive(tmp_path / "fleet", "k_good")
    _broken(tmp_path / "fleet", "k_ts_missing", "timestamps.txt")
    res = _run(["map", "fleet", "-o", "m.parquet"], tmp_path)
    assert res.exit_code == 1 and (tmp_path / "m.parquet").is_file()
    assert "FAILED fleet/k_ts_missing: not a KITTI raw drive" in res.output


# ------------------------------------------------------------------ row 12: export c --log without driving
def test_export_from_a_log_without_driving_warns(tmp_path):
    _csv(tmp_path / "standing.csv", vx=0.0)
    res = _run(["export", "c", "-e", "pif-modified", "--log", "standing.csv", "-o", "ex/"], tmp_path)
    assert res.exit_code == 0, res.output
    assert "warning: --log standing.csv: no driving to design on (the speed stays below 5 m/s); " \
           "using the default design" in res.output
    assert "(the default design for standing.csv)" in res.output and "fitted to" not in res.output
    _csv(tmp_path / "a.csv", n=3000)
    res = _run(["export", "c", "-e", "pif-modified", "--log", "a.csv", "-o", "ex2/"], tmp_path)
    # no word on the design (the reader's own warnings, as estimate prints them, may be there: a.csv's yaw
    # rate is constant 0)
    assert res.exit_code == 0 and "warning: --log" not in res.output and "fitted to a.csv" in res.output


def test_a_folder_inside_a_log_names_the_log_to_give():
    """``oxts/data`` of a drive (its frames, no log of their own) given for the drive: the one-line error names the
    folder that is the log; the drive itself reads."""
    _drive(Path.cwd(), "d1")
    res = _run(["estimate", "d1/oxts/data", "-e", "kinematic", "-o", "o.csv"], Path.cwd())
    assert res.exit_code == 1
    assert "error: no logs found in d1/oxts/data (parts of the log d1/oxts: give that folder)" in res.output
    assert _run(["estimate", "d1", "-e", "kinematic", "-o", "o.csv"], Path.cwd()).exit_code == 0


@pytest.mark.parametrize("part", ["d1/oxts/data/0000000007.txt", "d1/oxts/timestamps.txt"])
def test_a_file_inside_a_log_names_the_log_to_give(part):
    """One frame of a drive, or its time stamps, given for the drive: skipped as a part of the log and the one-line
    error names the folder that is the log (before: read as a table, "no data rows after the header"). A CSV put
    into the drive's folder is still read as the log it is."""
    _drive(Path.cwd(), "d1")
    res = _run(["estimate", part, "-e", "kinematic", "-o", "o.csv"], Path.cwd())
    assert res.exit_code == 1
    assert f"skipped {part} (a part of a log, not a log)" in res.output
    assert f"error: no logs left to read in {part} (parts of the log d1/oxts: give that folder)" in res.output
    _csv(Path("d1/mine.csv"))
    res = _run(["estimate", "d1/mine.csv", "-e", "kinematic", "-o", "o.csv"], Path.cwd())
    assert res.exit_code == 0, res.output
