"""Where `roadbank estimate` reads and writes: it never overwrites an input log, never reads its own outputs back
from a pattern, reads an MDF4 log with the map `roadbank channels` wrote for it, ignores unnamed empty columns, and
names the right problem of an output directory it cannot write into; a decimal comma is named."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io.writers import output_problem
from roadbank.sim import run_scenario


@pytest.fixture(scope="module")
def drive():
    """A simulated S-curve's inputs (t s, vx m/s, ay m/s^2, r rad/s) as a table."""
    s = run_scenario("s-curve").signals
    return pd.DataFrame({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r})


def _estimate(*args):
    return CliRunner().invoke(main, ["estimate", *map(str, args)])


def _theta(path: Path) -> np.ndarray:
    return pd.read_csv(path)["kinematic-pif.theta"].to_numpy()


def test_an_output_that_is_an_input_is_refused_and_the_log_kept(tmp_path, drive):
    log = tmp_path / "self.csv"
    drive.to_csv(log, index=False)
    before = log.read_bytes()
    res = _estimate(log, "-o", log)
    assert res.exit_code == 2 and "is one of the input logs" in res.output and "Traceback" not in res.output
    assert log.read_bytes() == before
    # in a batch: x.csv's result in the output directory would be x.bank.csv, which is another input
    x, xb = tmp_path / "x.csv", tmp_path / "x.bank.csv"
    drive.to_csv(x, index=False)
    drive.to_csv(xb, index=False)
    kept = xb.read_bytes()
    res = _estimate(x, xb, "-o", tmp_path, "--output-format", "csv")
    assert res.exit_code == 2 and f"the output '{xb}' is one of the input logs" in res.output, res.output
    assert xb.read_bytes() == kept


def test_a_pattern_leaves_out_the_outputs_a_folder_leaves_out(tmp_path, drive):
    folder = tmp_path / "g"
    folder.mkdir()
    drive.to_csv(folder / "a.csv", index=False)
    first = _estimate(folder, "-o", str(folder) + "/", "--output-format", "csv")
    assert first.exit_code == 0 and (folder / "a.bank.csv").exists() and (folder / "summary.csv").exists()
    theta = _theta(folder / "a.bank.csv")
    again = _estimate(str(folder / "*"), "-o", str(folder) + "/", "--output-format", "csv")
    assert again.exit_code == 0, again.output
    assert "1 log(s) written, 0 failed" in again.output and "FAILED" not in again.output
    np.testing.assert_array_equal(_theta(folder / "a.bank.csv"), theta)     # rewritten from a.csv, not from itself


def test_unnamed_empty_columns_are_ignored(tmp_path, drive):
    plain, trail = tmp_path / "plain.csv", tmp_path / "trail.csv"
    drive.to_csv(plain, index=False, float_format="%.10g")
    trail.write_text("".join(line + ",,\n" for line in plain.read_text().splitlines()))
    for p in (plain, trail):
        assert _estimate(p, "-o", p.with_suffix(".out.csv")).exit_code == 0
    np.testing.assert_array_equal(_theta(trail.with_suffix(".out.csv")), _theta(plain.with_suffix(".out.csv")))
    named = tmp_path / "dup.csv"
    named.write_text(plain.read_text().replace("t,vx,ay,r", "t,vx,ay,ay", 1))
    res = _estimate(named, "-o", tmp_path / "dup.out.csv")
    assert res.exit_code == 1 and "duplicate column name(s) ['ay']" in res.output


def test_the_map_channels_writes_for_an_mdf4_log_reads_it(tmp_path, drive):
    asammdf = pytest.importorskip("asammdf")
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(drive[c].to_numpy(), drive.t.to_numpy(), name=c) for c in ("vx", "ay", "r")])
    log = tmp_path / "log.mf4"
    mdf.save(log, overwrite=True)
    cmap = tmp_path / "map.toml"
    res = CliRunner().invoke(main, ["channels", str(log), "-o", str(cmap)])
    assert res.exit_code == 0 and "the map reads" in res.output, res.output
    assert "time" not in tomllib.loads(cmap.read_text())["channels"]             # MDF4 channels carry their own
    res = _estimate(log, "--channels", cmap, "-o", tmp_path / "out.csv")
    assert res.exit_code == 0 and (tmp_path / "out.csv").exists(), res.output
    # a table still needs its time column, and says so
    table = tmp_path / "log.csv"
    drive.to_csv(table, index=False)
    res = _estimate(table, "--channels", cmap, "-o", tmp_path / "t.csv")
    assert res.exit_code == 1 and "no 'time' channel (required for csv)" in res.output


def test_an_existing_directory_that_cannot_be_written_is_named_so(tmp_path, monkeypatch):
    """As root a directory cannot be made unwritable, so the access check is what is replaced here."""
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if Path(p) == tmp_path else real(p, mode))
    assert output_problem(tmp_path, directory=True) == (
        f"cannot write into directory '{tmp_path}': '{tmp_path}' is not writable (permission denied)")
    new = tmp_path / "new"
    assert output_problem(new, directory=True).startswith(f"cannot create directory '{new}'")


def test_a_decimal_comma_is_read_where_the_fields_are_not_separated_by_commas(tmp_path, drive):
    """A spreadsheet's export with ';' (or tabs) and decimal commas is read with its decimal comma, said once naming
    the file and the columns: the estimate is that of the same table written with '.', and channels maps it. Where
    the comma cannot be told from a thousands separator (a column that also holds a decimal point) or the fields are
    comma-separated (a quoted field), estimate refuses it naming the file, the column, the line and the decimal
    comma (channels leaves such a column out, as any column that is not numbers)."""
    plain, eu, tab = tmp_path / "plain.csv", tmp_path / "eu.csv", tmp_path / "tab.tsv"
    drive.to_csv(plain, index=False, float_format="%.9g")
    drive.to_csv(eu, sep=";", decimal=",", index=False, float_format="%.9g")
    drive.to_csv(tab, sep="\t", decimal=",", index=False, float_format="%.9g")
    assert "0,01" in eu.read_text()
    want = _estimate(plain, "-o", tmp_path / "plain.out.csv")
    assert want.exit_code == 0, want.output
    for log, sep in ((eu, "';'"), (tab, "tabs")):
        res = _estimate(log, "--format", "csv", "-o", tmp_path / f"{log.stem}.out.csv")
        assert res.exit_code == 0, res.output
        said = [ln for ln in res.output.splitlines() if "decimal mark" in ln]
        assert len(said) == 1 and log.name in said[0] and "'t', 'vx', 'ay', 'r'" in said[0] and sep in said[0], said
        np.testing.assert_array_equal(_theta(tmp_path / f"{log.stem}.out.csv"), _theta(tmp_path / "plain.out.csv"))
    res = CliRunner().invoke(main, ["channels", str(eu), "-o", str(tmp_path / "m.toml")])
    assert res.exit_code == 0 and (tmp_path / "m.toml").exists(), res.output
    lines = eu.read_text().splitlines()
    lines[2] = lines[2].replace(",", ".", 1)                  # one value of line 3 with a point: ambiguous
    mixed = tmp_path / "mixed.csv"
    mixed.write_text("\n".join(lines) + "\n")
    quoted = tmp_path / "quoted.csv"
    quoted.write_text("t,vx,ay,r\n" + "".join(f'{k / 100:g},20,"0,5",0.02\n' for k in range(300)))
    for log, line in ((mixed, "line 4"), (quoted, "line 2")):       # (the first field that is not a number)
        res = _estimate(log, "-o", tmp_path / "x.csv")
        assert res.exit_code == 1 and log.name in res.output and "looks like a decimal comma" in res.output, res.output
        assert line in res.output and "Traceback" not in res.output


@pytest.mark.parametrize("fmt, zone, offset_s", [("%Y-%m-%d %H:%M:%S.%f", "", 0.0), ("%Y-%m-%dT%H:%M:%S.%f", "Z", 0.0),
                                                  ("%Y-%m-%dT%H:%M:%S.%f", "+01:00", -3600.0)])
def test_a_time_column_of_iso_date_times_is_read_as_seconds(tmp_path, drive, fmt, zone, offset_s):
    """A logger's or spreadsheet's time stamps as ISO 8601 text (local or UTC, with an offset): read as seconds
    since the epoch (UTC, the offset applied, as the standard library's datetime reads them), the estimate that of
    the same log with its time in seconds; channels maps it; a date that is none (month 13) is refused naming the
    line."""
    from datetime import datetime, timedelta, timezone

    t0 = datetime(2026, 12, 6, 10, 0, 0, tzinfo=timezone.utc)
    stamps = [(t0 + timedelta(seconds=float(x))).strftime(fmt)[:-3] + zone for x in drive["t"]]
    iso = drive.assign(t=stamps)
    iso.to_csv(tmp_path / "iso.csv", index=False)
    drive.to_csv(tmp_path / "plain.csv", index=False, float_format="%.9g")
    for name in ("iso", "plain"):
        res = _estimate(tmp_path / f"{name}.csv", "-o", tmp_path / f"{name}.out.csv")
        assert res.exit_code == 0, res.output
    got = pd.read_csv(tmp_path / "iso.out.csv")
    np.testing.assert_allclose(got["t"].to_numpy(), t0.timestamp() + offset_s + drive["t"].to_numpy(), rtol=0,
                               atol=1e-6)
    np.testing.assert_allclose(got["kinematic-pif.theta"], _theta(tmp_path / "plain.out.csv"), rtol=0, atol=1e-6)
    res = CliRunner().invoke(main, ["channels", str(tmp_path / "iso.csv"), "-o", str(tmp_path / "m.toml")])
    assert res.exit_code == 0 and "time " in res.output and "'t' in s" in res.output, res.output
    stamps[3] = stamps[3].replace("2026-12-06", "2026-13-06")
    drive.assign(t=stamps).to_csv(tmp_path / "bad.csv", index=False)
    res = _estimate(tmp_path / "bad.csv", "-o", tmp_path / "x.csv")
    assert res.exit_code == 1 and "line 5" in res.output and "2026-13-06" in res.output, res.output


@pytest.mark.parametrize("args", [["estimate", "LOG", "-o", ""], ["reproduce", "-o", ""], ["map", "LOG", "-o", ""],
                                  ["estimate", "", "-o", "OUT"], ["validate", "kitti", ""],
                                  ["simulate", "s-curve", "-o", " "]])
def test_an_empty_path_is_a_usage_error(tmp_path, monkeypatch, args):
    """An empty path (``-o "$OUT"`` with OUT unset) is a usage error naming the option; before, ``-o ""`` wrote into
    the current folder (estimate its outputs, reproduce its report) and an empty LOGS read every log there."""
    monkeypatch.chdir(tmp_path)
    log = tmp_path / "log.csv"
    log.write_text("t,vx,ay,r\n0,10,0,0\n0.1,10,0,0\n")
    args = [str(log) if a == "LOG" else str(tmp_path / "out.csv") if a == "OUT" else a for a in args]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 2 and "an empty path" in res.output, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log.csv"]


@pytest.mark.parametrize("command, keys", [(["validate", "kitti", "EMPTY"], {"drives", "errors", "notes"}),
                                           (["validate", "comma2k19", "EMPTY"], {"segments", "errors", "notes"}),
                                           (["identify", "BAD", "-o", "OUT"], {"quantities", "logs", "error"})])
def test_json_is_printed_when_every_input_fails(tmp_path, command, keys):
    """--json with nothing read: exit 1 and a JSON object on stdout with the command's keys, nothing scored and the
    reasons (before: an empty stdout, while estimate --json printed one)."""
    import json

    (tmp_path / "empty").mkdir()
    (tmp_path / "bad.csv").write_text("")
    args = [str(tmp_path / "empty") if a == "EMPTY" else str(tmp_path / "bad.csv") if a == "BAD"
            else str(tmp_path / "id.toml") if a == "OUT" else a for a in command]
    res = CliRunner().invoke(main, [*args, "--json"])
    assert res.exit_code == 1, res.output
    out = json.loads(res.stdout)
    assert set(out) == keys, out
    assert str(tmp_path) in json.dumps(out)            # the reason names the input


@pytest.mark.parametrize("inside, folder", [("report.md", True), ("report.html", True), ("figures", False)])
def test_reproduce_checks_what_it_writes_inside_its_folder_first(tmp_path, inside, folder):
    """report.md a folder, or figures a file, in the output folder: a usage error naming it before the study runs
    (before: the study ran, then "Is a directory" or a cryptic "File exists")."""
    out = tmp_path / "rep"
    out.mkdir()
    (out / inside).mkdir() if folder else (out / inside).write_text("")
    res = CliRunner().invoke(main, ["reproduce", "-o", str(out), "--scenarios", "const-bank",
                                    "--estimators", "kinematic"])
    assert res.exit_code == 2 and "cannot " in res.output and str(out / inside) in res.output, res.output
    assert sorted(p.name for p in out.iterdir()) == [inside]
