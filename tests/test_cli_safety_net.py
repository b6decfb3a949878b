"""What the file system and the command line's last resort do with what no reader foresaw: a FIFO, a link loop, a
folder that cannot be searched, files named as roadbank's outputs, a Parquet schema with a name twice, and any error
that reaches the command line unhandled (one line naming the file, never a traceback). Simulated logs in tmp_path."""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import TRACEBACK_ENV, main
from roadbank.fleet import expand_logs
from roadbank.io import LogError, load_log
from roadbank.io.files import must_exist
from roadbank.sim import run_scenario


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def frame() -> pd.DataFrame:
    s = run_scenario("s-curve").signals
    return pd.DataFrame({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r})


@pytest.fixture
def folder(tmp_path, frame) -> Path:
    d = tmp_path / "logs"
    d.mkdir()
    frame.to_csv(d / "good.csv", index=False, float_format="%.10g")
    return d


def test_an_unhandled_error_is_one_line_naming_the_file(tmp_path, folder, monkeypatch):
    """With the traceback switch unset, an OSError that reached the command line is the file and the system's reason,
    anything else its type and text as a bug (exit code 1); with it set, the error itself comes out."""
    import roadbank.fleet

    def refused(args, left_out=None):
        raise PermissionError(13, "Permission denied", str(folder / "x.csv"))

    def broken(args, left_out=None):
        raise ValueError("boom")

    monkeypatch.delenv(TRACEBACK_ENV)
    monkeypatch.setattr(roadbank.fleet, "expand_logs", refused)
    res = _run("estimate", folder, "-o", tmp_path / "out")
    assert res.exit_code == 1 and "Traceback" not in res.output
    assert res.output.strip() == f"error: {folder / 'x.csv'}: Permission denied"
    monkeypatch.setattr(roadbank.fleet, "expand_logs", broken)
    res = _run("estimate", folder, "-o", tmp_path / "out")
    assert res.exit_code == 1 and "unexpected ValueError: boom" in res.output and "a bug in roadbank" in res.output
    monkeypatch.setenv(TRACEBACK_ENV, "1")
    assert isinstance(_run("estimate", folder, "-o", tmp_path / "out").exception, ValueError)


def test_ctrl_c_ends_with_the_shells_code_for_it(tmp_path, folder, monkeypatch):
    """Ctrl-C in a command ends with exit code 130 (128 + SIGINT) and one line, told apart from a failed log (1) and
    a usage error (2); it was click's 'Aborted!' with 1."""
    import roadbank.fleet

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(roadbank.fleet, "estimate_log", interrupted)
    res = _run("estimate", folder / "good.csv", "-o", tmp_path / "out.csv")
    assert res.exit_code == 130 and res.output.strip() == "interrupted (Ctrl-C)", res.output


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_a_fifo_is_refused_not_waited_on(tmp_path, folder):
    """A FIFO named like a log, in a folder and given by name: refused at once (the batch's exit code 1: a log
    failed), the folder's other log written."""
    os.mkfifo(folder / "pipe.csv")
    with pytest.raises(LogError, match="pipe.csv: neither a file nor a folder"):
        must_exist(folder / "pipe.csv")
    res = _run("estimate", folder, "-o", tmp_path / "out")
    assert res.exit_code == 1 and "1 log(s) written, 1 failed" in res.output, res.output
    assert "FAILED" in res.output and "pipe.csv: neither a file nor a folder" in res.output
    assert (tmp_path / "out" / "good.bank.parquet").is_file()


def test_a_link_loop_lists_each_log_once(tmp_path, folder):
    (folder / "sub").mkdir()
    (folder / "sub" / "up").symlink_to(folder, target_is_directory=True)
    assert [p.name for p in expand_logs([folder])] == ["good.csv"]


def test_a_folder_that_cannot_be_searched_is_reported_not_raised(tmp_path, folder, monkeypatch):
    """An entry that cannot be looked at (the system refuses the stat) is listed as a log, and the reader then says
    it cannot be read, naming it; the folder's other logs are listed as always. (Simulated: the tests may run as root,
    whom no permission stops.)"""
    locked = folder / "locked"
    locked.mkdir()
    real_stat = Path.stat

    def stat(self, *a, **kw):
        if self == locked:
            raise PermissionError(13, "Permission denied", str(self))
        return real_stat(self, *a, **kw)

    monkeypatch.setattr(Path, "stat", stat)
    assert sorted(p.name for p in expand_logs([folder])) == ["good.csv", "locked"]
    with pytest.raises(LogError, match="locked: cannot be read \\(Permission denied\\)"):
        must_exist(locked)


def test_files_named_as_outputs_are_left_out_and_said(tmp_path, folder, frame):
    frame.to_csv(folder / "summary.csv", index=False)
    frame.to_csv(folder / "old.bank.csv", index=False)
    left: list = []
    assert [p.name for p in expand_logs([folder], left)] == ["good.csv"]
    assert sorted(p.name for p in left) == ["old.bank.csv", "summary.csv"]
    res = CliRunner().invoke(main, ["estimate", str(folder), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0 and "note: 2 file(s) named as roadbank's own outputs" in res.output


def test_a_parquet_schema_with_a_name_twice_is_refused_naming_it(tmp_path, frame):
    p = tmp_path / "dup.parquet"
    cols = [pa.array(frame[c].to_numpy()) for c in ("t", "vx", "ay", "r", "r")]
    pq.write_table(pa.Table.from_arrays(cols, names=["t", "vx", "ay", "r", "r"]), p)
    with pytest.raises(LogError, match=r"dup.parquet: duplicate column name\(s\) \['r'\] in the schema"):
        load_log(p)
    res = _run("channels", p, "-o", tmp_path / "m.toml")
    assert res.exit_code == 1 and "duplicate column name(s) ['r']" in res.output and "Traceback" not in res.output


def test_a_map_flag_or_ratio_that_is_not_one_is_refused():
    """``invert = "false"`` (a string, which Python reads as true) and a steering ratio no road vehicle has are
    refused naming the map, the channel or key, and the value; a boolean and a plausible ratio are read."""
    from roadbank.io.channels import channel_map_from_dict
    base = {"time": {"column": "t", "unit": "s"}, "speed": {"column": "vx", "unit": "m/s"},
            "lateral_acceleration": {"column": "ay", "unit": "m/s^2"}, "yaw_rate": {"column": "r", "unit": "rad/s"}}
    with pytest.raises(LogError, match="m.toml: channel 'yaw_rate' \\(column 'r'\\): 'invert' must be true or false"):
        channel_map_from_dict({"channels": {**base, "yaw_rate": {"column": "r", "unit": "rad/s", "invert": "false"}}},
                              "m.toml")
    assert channel_map_from_dict({"channels": {**base, "yaw_rate": {"column": "r", "unit": "rad/s", "invert": True}}},
                                 "m.toml").channels["yaw_rate"].invert is True
    with pytest.raises(LogError, match="m.toml: steering_ratio = 1e\\+06 is outside a road vehicle's 5-30"):
        channel_map_from_dict({"channels": base, "steering_ratio": 1e6}, "m.toml")
    assert channel_map_from_dict({"channels": base, "steering_ratio": 14.5}, "m.toml").steering_ratio == 14.5


def test_a_steering_ratio_option_outside_a_road_vehicle_is_a_usage_error(tmp_path, folder):
    res = _run("estimate", folder / "good.csv", "--steering-ratio", "1e300", "-o", tmp_path / "o.csv")
    assert res.exit_code == 2 and "outside a road vehicle's 5-30" in res.output and not (tmp_path / "o.csv").exists()
