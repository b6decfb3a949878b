"""A log path that does not exist is said to be not found, naming it (never a word on its suffix): a usage error
(exit code 2) when no path given exists, that log's failure among others. ``export c --log`` prints the log's
reader warnings as ``estimate`` does. Simulated logs written to tmp_path; each command designs one estimator."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io import LogError, detect_format, load_log
from roadbank.sim import run_scenario


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def drive_csv(tmp_path_factory) -> Path:
    """A simulated S-curve (t, vx, ay, r at 100 Hz) as CSV, its last line cut inside its last number."""
    s = run_scenario("s-curve").signals
    p = tmp_path_factory.mktemp("logs") / "drive.csv"
    pd.DataFrame({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r}).to_csv(p, index=False, float_format="%.10g")
    return p


@pytest.fixture(scope="module")
def cut_csv(drive_csv) -> Path:
    text = drive_csv.read_text().rstrip("\n")
    cut = drive_csv.parent / "cut.csv"
    head, last = text.rsplit(",", 1)
    cut.write_text(f"{head},{last[:2]}")  # cut in its last number: the reader leaves the line out with a warning
    return cut


def _says_not_found(res, path) -> None:
    assert "Traceback" not in res.output
    assert f"{path}: not found (no such file or folder)" in res.output, res.output
    assert "suffix" not in res.output


@pytest.mark.parametrize("cmd", [["estimate", "-o", "out.csv"], ["identify", "-o", "car.toml"],
                                 ["map", "-o", "m.parquet"]])
def test_a_log_path_that_does_not_exist_is_a_usage_error_naming_it(tmp_path, cmd):
    missing = tmp_path / "no_such_drive"
    res = _run(cmd[0], missing, *[a if not a.endswith(("csv", "toml", "parquet")) else tmp_path / a for a in cmd[1:]])
    assert res.exit_code == 2
    _says_not_found(res, missing)
    assert not list(tmp_path.iterdir())                     # nothing written


def test_several_missing_paths_are_each_named(tmp_path):
    a, b = tmp_path / "a_drive", tmp_path / "b.csv"
    res = _run("estimate", a, b, "-o", tmp_path / "out")
    assert res.exit_code == 2
    _says_not_found(res, a)
    _says_not_found(res, b)


def test_a_missing_path_among_logs_fails_alone(tmp_path, drive_csv):
    missing = tmp_path / "no_such_drive"
    res = _run("estimate", drive_csv, missing, "-e", "kinematic", "-o", tmp_path / "out")
    assert res.exit_code == 1
    _says_not_found(res, missing)
    assert (tmp_path / "out" / "drive.bank.parquet").is_file()
    assert "1 log(s) written, 1 failed" in res.output


def test_the_readers_say_not_found(tmp_path):
    for p in (tmp_path / "no_such_drive", tmp_path / "x.csv"):
        with pytest.raises(LogError, match=r"no_such_drive|x\.csv") as err:
            detect_format(p)
        assert str(err.value) == f"{p}: not found (no such file or folder)"
        with pytest.raises(LogError, match="not found"):
            load_log(p)
        with pytest.raises(LogError, match="not found"):
            load_log(p, format="csv")


def test_export_c_names_a_log_that_does_not_exist(tmp_path):
    res = _run("export", "c", "--log", tmp_path / "no_such_drive", "-o", tmp_path / "ecu")
    assert res.exit_code == 1            # as tests/test_export_c.py has it: the --log error of the reader
    _says_not_found(res, tmp_path / "no_such_drive")
    assert not (tmp_path / "ecu").exists()


def test_export_c_prints_the_logs_reader_warnings(tmp_path, cut_csv):
    said = [w for w in load_log(cut_csv).warnings if "was left out" in w]
    assert len(said) == 1
    res = _run("export", "c", "-e", "pif-modified", "--log", cut_csv, "-o", tmp_path / "ecu")
    assert res.exit_code == 0, res.output
    assert f"warning: {said[0]}" in res.stderr and "Traceback" not in res.output
    # as estimate prints it
    est = _run("estimate", cut_csv, "-e", "kinematic", "-o", tmp_path / "o.csv")
    assert f"warning: {said[0]}" in est.stderr
