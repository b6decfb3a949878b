"""Inputs given as folders, and CSV files with comment lines before the header.

A folder given to ``roadbank estimate`` gives every log it holds (each KITTI drive, comma2k19 segment and log
file), never only its KITTI drives; a folder that is one drive, its ``oxts/`` folder, or a folder holding one drive
and nothing else stays one log, named after the drive. A CSV may start with ``#`` comment lines; every message
still names the file's own line.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.fleet import expand_logs
from roadbank.io import LogError, load_log
from roadbank.io.readers import read_csv

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
D0070 = DATA / "kitti-oxts" / "2011_09_26_drive_0070"
D0047 = DATA / "kitti-oxts" / "2011_10_03_drive_0047"
SEGMENT = DATA / "comma2k19-example"
needs_data = pytest.mark.skipif(not all(p.is_dir() for p in (D0070, D0047, SEGMENT)),
                                reason=f"shared data (KITTI drives 0070 and 0047, comma2k19 segment) absent at {DATA}")


def _run(*args) -> object:
    """``roadbank ARGS``: never a traceback."""
    res = CliRunner().invoke(main, [str(a) for a in args])
    assert "Traceback" not in res.output, res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    return res


def _csv(path: Path, bank: float, n: int = 400) -> Path:
    """A straight road banked ``bank`` rad in roadbank's own columns, 100 Hz: the kinematic estimate is exactly
    ``bank`` (ay = g sin(bank), r = 0)."""
    t = np.arange(n) * 0.01
    rows = "\n".join(f"{a:.2f},20,{9.81 * np.sin(bank):.12f},0,0" for a in t)
    path.write_text("t,vx,ay,r,delta_f\n" + rows + "\n")
    return path


def _link(src: Path, dst: Path) -> Path:
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.symlink_to(src, target_is_directory=True)
    return dst


def _frames(drive: Path) -> np.ndarray:
    """The INS roll (rad, oxts column 3) of every frame of a drive, read from its frame files."""
    files = sorted((drive / "oxts" / "data").glob("*.txt"))
    return np.array([float(f.read_text().split()[3]) for f in files])


def _summary(out: Path) -> dict[str, dict]:
    with open(out / "summary.csv", newline="") as fh:
        return {Path(r["output"]).name: r for r in csv.DictReader(fh)}


def _check_drive(table_file: Path, drive: Path) -> None:
    """The output of ``drive``: one row a frame, its reference roll that drive's INS roll."""
    tab = pq.read_table(table_file)
    roll = _frames(drive)
    assert tab.num_rows == len(roll) == len((drive / "oxts" / "timestamps.txt").read_text().split("\n")) - 1
    np.testing.assert_allclose(tab.column("reference_roll").to_numpy(), roll, atol=1e-9)


def _check_csv(table_file: Path, bank: float, n: int = 400) -> None:
    tab = pq.read_table(table_file)
    assert tab.num_rows == n
    np.testing.assert_allclose(tab.column("kinematic.theta").to_numpy(), bank, atol=1e-9)


# ------------------------------------------------------------------ a folder: every log it holds
@needs_data
def test_a_drive_beside_a_csv_does_not_hide_it(tmp_path):
    fleet = tmp_path / "fleetdir"
    _link(D0070, fleet / D0070.name)
    _csv(fleet / "drive_b.csv", 0.02)
    res = _run("estimate", fleet, "-e", "kinematic", "-o", f"{tmp_path / 'out'}/")
    assert res.exit_code == 0, res.output
    assert "2 log(s) written, 0 failed" in res.output
    out = tmp_path / "out"
    assert sorted(p.name for p in out.iterdir()) == [f"{D0070.name}.bank.parquet", "drive_b.bank.parquet",
                                                    "settings.json", "summary.csv"]
    rows = _summary(out)
    assert {r["status"] for r in rows.values()} == {"ok"}
    assert rows["drive_b.bank.parquet"]["log"] == str(fleet / "drive_b.csv")
    assert rows[f"{D0070.name}.bank.parquet"]["log"] == str(fleet / D0070.name)
    _check_drive(out / f"{D0070.name}.bank.parquet", D0070)
    _check_csv(out / "drive_b.bank.parquet", 0.02)
    # a glob over the folder gives the same logs
    glob_out = tmp_path / "glob"
    res = _run("estimate", f"{fleet}/*", "-e", "kinematic", "-o", f"{glob_out}/")
    assert res.exit_code == 0 and sorted(p.name for p in glob_out.iterdir()) == sorted(p.name for p in out.iterdir())


@needs_data
def test_two_drives_and_a_csv_give_three_logs(tmp_path):
    fleet = tmp_path / "fd2"
    _link(D0070, fleet / D0070.name)
    _link(D0047, fleet / D0047.name)
    _csv(fleet / "drive_c.csv", -0.01)
    res = _run("estimate", fleet, "-e", "kinematic", "-o", f"{tmp_path / 'out'}/")
    assert res.exit_code == 0 and "3 log(s) written, 0 failed" in res.output, res.output
    out = tmp_path / "out"
    _check_drive(out / f"{D0070.name}.bank.parquet", D0070)
    _check_drive(out / f"{D0047.name}.bank.parquet", D0047)
    _check_csv(out / "drive_c.bank.parquet", -0.01)
    assert len(_summary(out)) == 3


@needs_data
def test_a_drive_beside_a_comma2k19_segment(tmp_path):
    fleet = tmp_path / "fd3"
    _link(D0070, fleet / D0070.name)
    _link(SEGMENT, fleet / "seg")
    res = _run("estimate", fleet, "-e", "kinematic", "-o", f"{tmp_path / 'out'}/")
    assert res.exit_code == 0 and "2 log(s) written, 0 failed" in res.output, res.output
    out = tmp_path / "out"
    assert sorted(p.name for p in out.iterdir()) == [f"{D0070.name}.bank.parquet", "seg.bank.parquet", "settings.json",
                                                     "summary.csv"]
    _check_drive(out / f"{D0070.name}.bank.parquet", D0070)
    # the segment's table is the one the segment given alone gives
    res = _run("estimate", SEGMENT, "-e", "kinematic", "-o", tmp_path / "alone.parquet")
    assert res.exit_code == 0, res.output
    a, b = pq.read_table(out / "seg.bank.parquet"), pq.read_table(tmp_path / "alone.parquet")
    assert a.num_rows == b.num_rows > 0
    for c in ("t", "kinematic.theta", "reference_roll"):
        np.testing.assert_array_equal(a.column(c).to_numpy(), b.column(c).to_numpy())


@needs_data
def test_nested_folders_and_a_broken_drive(tmp_path):
    """A sub-folder holding one drive and nothing else stays that log (named after the drive); one holding a
    drive and a CSV gives both; a drive short of its time stamps is a failed log; the others are written."""
    fleet = tmp_path / "fleet"
    _link(D0070, fleet / "only" / D0070.name)
    _link(D0047, fleet / "mixed" / D0047.name)
    _csv(fleet / "mixed" / "m.csv", 0.01)
    _csv(fleet / "top.csv", 0.03)
    (fleet / "k_broken" / "oxts" / "data").mkdir(parents=True)
    assert expand_logs([fleet]) == sorted([fleet / "only", fleet / "mixed" / D0047.name, fleet / "mixed" / "m.csv",
                                           fleet / "top.csv", fleet / "k_broken"])
    res = _run("estimate", fleet, "-e", "kinematic", "-o", f"{tmp_path / 'out'}/")
    assert res.exit_code == 1 and "4 log(s) written, 1 failed" in res.output, res.output
    assert f"FAILED {fleet / 'k_broken'}: not a KITTI raw drive" in res.output
    out = tmp_path / "out"
    assert sorted(p.name for p in out.glob("*.bank.parquet")) == sorted(
        [f"{D0070.name}.bank.parquet", f"{D0047.name}.bank.parquet", "m.bank.parquet", "top.bank.parquet"])
    _check_drive(out / f"{D0070.name}.bank.parquet", D0070)
    _check_drive(out / f"{D0047.name}.bank.parquet", D0047)
    _check_csv(out / "m.bank.parquet", 0.01)
    _check_csv(out / "top.bank.parquet", 0.03)


@needs_data
@pytest.mark.parametrize("form", ["drive", "oxts", "parent"])
def test_a_folder_that_is_one_drive_is_one_log_as_before(tmp_path, form):
    parent = tmp_path / "kitti_date"
    drive = _link(D0070, parent / D0070.name)
    (parent / "calib_cam_to_cam.txt").write_text("calib_time: 09-Jan-2012 13:57:47\n")    # not a log
    given = {"drive": drive, "oxts": drive / "oxts", "parent": parent}[form]
    assert expand_logs([given]) == [given]
    res = _run("estimate", given, "-e", "kinematic", "-o", tmp_path / "one.parquet")     # one log: a file
    assert res.exit_code == 0 and "1 log(s) written, 0 failed" in res.output, res.output
    _check_drive(tmp_path / "one.parquet", D0070)
    res = _run("estimate", given, "-e", "kinematic", "-o", f"{tmp_path / 'out'}/")
    assert res.exit_code == 0, res.output
    name = f"{D0070.name}.bank.parquet"               # the drive's name, whichever of its folders was given
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [name, "settings.json", "summary.csv"]
    assert _summary(tmp_path / "out")[name]["log"] == str(given)
    _check_drive(tmp_path / "out" / name, D0070)


@needs_data
def test_a_drive_given_as_its_folder_and_its_oxts_folder_is_one_log(tmp_path):
    """A drive given twice, as its folder and as its ``oxts/`` folder: written once under the drive's name, the second
    said on stderr (it was written twice, once as oxts.bank.parquet, and mapped twice)."""
    res = _run("estimate", D0070, D0070 / "oxts", _csv(tmp_path / "a.csv", 0.02), "-e", "kinematic",
               "-o", tmp_path / "out")
    assert res.exit_code == 0, res.output
    assert f"{D0070 / 'oxts'} is {D0070} given again (the same log): read once" in res.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [f"{D0070.name}.bank.parquet", "a.bank.parquet",
                                                                    "settings.json", "summary.csv"]


def test_a_link_loop_or_an_unreadable_file_fails_alone(tmp_path, monkeypatch):
    """In a folder of logs, a link to itself and a file that cannot be read each fail as that log, named, and the
    other log is written (the loop stopped the whole run with a RuntimeError; the unreadable file was skipped as
    'not a log of a known format' and counted nowhere)."""
    import roadbank.io.files as files

    d = tmp_path / "logs"
    d.mkdir()
    _csv(d / "good.csv", 0.02)
    (d / "loop.csv").symlink_to("loop.csv")
    locked = _csv(d / "locked.csv", 0.02)
    real_access = files.os.access
    monkeypatch.setattr(files.os, "access", lambda p, mode: False if Path(p) == locked else real_access(p, mode))
    res = _run("estimate", d, "-e", "kinematic", "-o", tmp_path / "out")
    assert res.exit_code == 1, res.output
    assert "loop.csv: cannot be read" in res.output and "locked.csv: a file that cannot be read" in res.output
    assert "skipped" not in res.output and "1 log(s) written, 2 failed" in res.output
    assert (tmp_path / "out" / "good.bank.parquet").is_file()


# ------------------------------------------------------------------ CSV: comment lines before the header
def _body(n: int = 300, delim: str = ",", dup: int | None = None) -> tuple[str, list[float]]:
    """Header and rows of a 100 Hz log on a straight road banked 0.02 rad (with a steering column, so
    ``roadbank channels`` finds every channel); ``dup``: that row repeats the stamp of the one before."""
    t = list(np.round(np.arange(n) * 0.01, 2))
    if dup is not None:
        t[dup] = t[dup - 1]
    ay = 9.81 * np.sin(0.02) + 0.05 * np.sin(2 * np.pi * 0.3 * np.arange(n) * 0.01)
    r = 0.05 * np.sin(2 * np.pi * 0.3 * np.arange(n) * 0.01) / 20.0
    head = delim.join(["t", "vx", "ay", "r", "delta_f"])
    rows = [delim.join(f"{v:.6g}" for v in (a, 20.0, b, c, 2.7 * c / 20.0)) for a, b, c in zip(t, ay, r)]
    return head + "\n" + "\n".join(rows) + "\n", t


COMMENTS = {
    "one": "# logger v1.2, car 7\n",
    "indented": "   \t# logger v1.2, car 7\n",
    "several and blank": "# logger v1.2, car 7\n\n# 2026-12-04; t in s\n#\n",
    "bom": "\ufeff# logger v1.2, car 7\n",
}


@pytest.mark.parametrize("delim", [",", ";"])
@pytest.mark.parametrize("kind", list(COMMENTS))
def test_comment_lines_before_the_header_are_skipped(tmp_path, kind, delim):
    body, _ = _body(delim=delim)
    plain, commented = tmp_path / "plain.csv", tmp_path / "commented.csv"
    plain.write_text(body)
    commented.write_text(COMMENTS[kind] + body, encoding="utf-8-sig" if kind == "bom" else "utf-8")
    res = _run("estimate", commented, "-e", "kinematic", "-o", tmp_path / "c.csv")
    assert res.exit_code == 0 and "1 log(s) written, 0 failed" in res.output, res.output
    assert _run("estimate", plain, "-e", "kinematic", "-o", tmp_path / "p.csv").exit_code == 0
    assert (tmp_path / "c.csv").read_text() == (tmp_path / "p.csv").read_text()      # read as if no comment
    skipped = COMMENTS[kind].count("\n")
    raw = read_csv(commented, {"t": "time"})
    assert list(raw.rownums) == list(range(skipped + 2, skipped + 302))                # the file's own lines
    # roadbank channels: the same map as for the file without comments
    res_c = _run("channels", commented, "-o", tmp_path / "c.toml")
    res_p = _run("channels", plain, "-o", tmp_path / "p.toml")
    assert res_c.exit_code == res_p.exit_code == 0, res_c.output
    strip = lambda f: [x for x in f.read_text().splitlines() if "roadbank channels" not in x]   # noqa: E731
    assert strip(tmp_path / "c.toml") == strip(tmp_path / "p.toml")
    assert 'time = { column = "t", unit = "s" }' in (tmp_path / "c.toml").read_text()


def _line_of(path: Path, pred) -> int:
    """1-based number of the first line of ``path`` for which ``pred(fields, next_fields)`` holds."""
    lines = path.read_text().splitlines()
    for i, line in enumerate(lines):
        if pred(line.split(","), lines[i + 1].split(",") if i + 1 < len(lines) else None):
            return i + 1
    raise AssertionError("no such line")


def test_a_truncated_row_after_comments_names_its_own_line(tmp_path):
    body, _ = _body()
    lines = body.splitlines()
    lines[150] = lines[150][:lines[150].index(",", 5) + 2]     # cut mid-row: '1.49,20,0'
    p = tmp_path / "cut.csv"
    p.write_text("# logger v1.2, car 7\n# second comment\n" + "\n".join(lines) + "\n")
    cut = _line_of(p, lambda f, _: len(f) == 3 and not f[0].startswith("#"))
    assert cut == 153
    msg = f"line {cut} has 3 field(s) but the header has 5 (truncated or corrupt file)"
    with pytest.raises(LogError, match=re.escape(msg)):
        load_log(p)
    res = _run("estimate", p, "-e", "kinematic", "-o", tmp_path / "o.csv")
    assert res.exit_code == 1 and f"FAILED {p}: {msg}" in res.output
    res = _run("channels", p, "-o", tmp_path / "m.toml")
    assert res.exit_code == 1 and f"error: {p}: {msg}" in res.output


def test_bad_value_and_repaired_stamp_after_comments_name_their_own_lines(tmp_path):
    body, _ = _body()
    p = tmp_path / "bad.csv"
    p.write_text("# logger v1.2, car 7\n" + body.replace("\n0.5,", "\n0.5x,", 1))
    bad = _line_of(p, lambda f, _: f[0] == "0.5x")
    with pytest.raises(LogError, match=rf"channel 'time' \(column 't'\): non-numeric value '0.5x' at line {bad}$"):
        load_log(p)
    body, _ = _body(dup=100)
    p = tmp_path / "dup.csv"
    p.write_text("# one\n\n# two\n" + body)
    first = _line_of(p, lambda f, g: g is not None and f[0] == g[0] and f[0] != "t")
    log = load_log(p)
    assert any(f"1 duplicate stamp dropped (first at line {first})" in w for w in log.warnings), log.warnings


def test_comments_elsewhere_get_true_messages(tmp_path):
    body, _ = _body()
    lines = body.splitlines()
    p = tmp_path / "mid.csv"
    p.write_text("\n".join(lines[:50] + ["# paused"] + lines[50:]) + "\n")
    with pytest.raises(LogError) as err:
        load_log(p)
    assert str(err.value) == (f"{p}: line 51 is a comment ('# paused'): comment lines starting with '#' are read "
                              "only before the header")
    # a header written as a comment (numpy.savetxt's header=): not the first data row taken for the header
    p = tmp_path / "savetxt.csv"
    p.write_text("# " + body)
    with pytest.raises(LogError, match=r"no header line: line 2 \('0,20,.*holds numbers, not column names"):
        load_log(p)
    p = tmp_path / "only_comments.csv"
    p.write_text("# nothing\n\n# here\n")
    with pytest.raises(LogError, match="no header line"):
        load_log(p)


def test_a_pattern_or_a_folder_that_gives_no_log_is_said(tmp_path, monkeypatch):
    """Among inputs that give logs, a pattern that matches no file and a folder without logs are each said in a note
    (they were passed over without a word); the other logs are written."""
    monkeypatch.chdir(tmp_path)
    _csv(tmp_path / "a.csv", 0.02)
    (tmp_path / "empty").mkdir()
    res = _run("estimate", "nomatch*.csv", "empty", "a.csv", "-e", "kinematic", "-o", "out/")
    assert res.exit_code == 0, res.output
    assert "note: nomatch*.csv: the pattern matches no file" in res.output
    assert "note: empty: a folder without logs" in res.output
    assert (tmp_path / "out" / "a.bank.parquet").is_file()
