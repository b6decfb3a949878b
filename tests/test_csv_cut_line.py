"""A CSV log whose last line has no final newline may have been cut off while it was written: the line is
left out with a warning naming the file and line, and the log reads as the same file without that line
(tmp_path copies of a simulated drive). A last line short of fields is refused as truncated."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.io import LogError, load_log
from roadbank.sim import run_scenario

FMT = "%.10g"


@pytest.fixture(scope="module")
def drive():
    """A simulated S-curve's inputs (t s, vx m/s, ay m/s^2, r rad/s) as a table, 100 Hz."""
    s = run_scenario("s-curve").signals
    return pd.DataFrame({"t": s.t, "vx": s.vx, "ay": s.ay, "r": s.r})


@pytest.fixture()
def plain(tmp_path, drive) -> Path:
    p = tmp_path / "plain.csv"
    drive.to_csv(p, index=False, float_format=FMT)
    return p


def _signals(log):
    s = log.signals
    return np.column_stack([s.t, s.vx, s.ay, s.r])


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _theta(path: Path) -> np.ndarray:
    return pd.read_csv(path)["kinematic-pif.theta"].to_numpy()


@pytest.fixture()
def long_last(tmp_path, drive) -> Path:
    """The plain log with its last yaw rate -0.00095032141 rad/s, a number a cut can leave as ``-0``."""
    d = drive.copy()
    d.loc[d.index[-1], "r"] = -0.00095032141
    p = tmp_path / "long_last.csv"
    d.to_csv(p, index=False, float_format=FMT)
    assert p.read_text().endswith(",-0.00095032141\n")
    return p


def _without_last_row(tmp_path, plain) -> Path:
    lines = plain.read_text().splitlines()
    short = tmp_path / "short.csv"
    short.write_text("\n".join(lines[:-1]) + "\n")
    return short


@pytest.mark.parametrize("how", ["number", "newline"])
def test_an_unfinished_last_line_is_left_out_with_a_warning(tmp_path, long_last, how):
    """Cut inside the last number (``-0`` of ``-0.00095032141``: the field count right) or after it (a complete
    file lacking only its final newline)."""
    plain = long_last
    text = plain.read_text().rstrip("\n")
    cut_file = tmp_path / "cut.csv"
    cut_file.write_text({"number": text[:-11], "newline": text}[how])
    assert how != "number" or cut_file.read_text().splitlines()[-1].count(",") == 3
    n_lines = len(text.splitlines())
    log = load_log(cut_file)
    ref = load_log(_without_last_row(tmp_path, plain))
    np.testing.assert_array_equal(_signals(log), _signals(ref))
    assert len(log) == len(load_log(plain)) - 1                      # only that one line is lost
    said = [w for w in log.warnings if f"line {n_lines} was left out" in w]
    assert len(said) == 1 and said[0].startswith(f"{cut_file}: ") and "no final newline" in said[0]
    assert not [w for w in ref.warnings if "was left out" in w]


def test_a_last_line_cut_short_of_fields_is_refused_as_truncated(tmp_path, plain):
    text = plain.read_text().rstrip("\n")
    cut_file = tmp_path / "cut.csv"
    cut_file.write_text(text.rsplit(",", 2)[0])
    with pytest.raises(LogError, match=rf"cut\.csv: line {len(text.splitlines())} has 2 field\(s\) but the header has "
                                       r"4 \(truncated or corrupt file\)"):
        load_log(cut_file)


def test_estimate_warns_of_the_unfinished_line_and_estimates_the_rest(tmp_path, long_last):
    plain = long_last
    text = plain.read_text().rstrip("\n")
    cut_file = tmp_path / "cut.csv"
    cut_file.write_text(text[:-11])
    res = _run("estimate", cut_file, "-o", tmp_path / "cut.out.csv")
    assert res.exit_code == 0, res.output
    assert f"warning: {cut_file}: line {len(text.splitlines())} was left out" in res.output
    assert _run("estimate", _without_last_row(tmp_path, plain), "-o", tmp_path / "short.out.csv").exit_code == 0
    np.testing.assert_array_equal(_theta(tmp_path / "cut.out.csv"), _theta(tmp_path / "short.out.csv"))


@pytest.mark.parametrize("ending", ["\n", "\r\n", "\r"])   # "\r": cut between the CR and LF of its last line
def test_a_finished_last_line_is_kept(tmp_path, plain, ending):
    lines = plain.read_text().splitlines()
    f = tmp_path / "ends.csv"
    f.write_bytes(("\r\n".join(lines) + ending).encode() if ending != "\n" else ("\n".join(lines) + "\n").encode())
    log = load_log(f)
    np.testing.assert_array_equal(_signals(log), _signals(load_log(plain)))
    assert not [w for w in log.warnings if "was left out" in w]


def test_a_single_data_line_without_newline_is_not_dropped(tmp_path, plain):
    lines = plain.read_text().splitlines()
    f = tmp_path / "one_row.csv"
    f.write_text(lines[0] + "\n" + lines[1])
    with pytest.raises(LogError) as err:        # one sample is too short a log, but the line was read
        load_log(f)
    assert "no data rows" not in str(err.value) and "was left out" not in str(err.value)
