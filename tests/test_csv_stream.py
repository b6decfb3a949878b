"""A CSV file above ``csvtable.CSV_WHOLE_BYTES`` is streamed in blocks of lines (``csvtable.CsvLines``), in bounded
memory: the same values, line numbers, warnings and errors as read whole (``read_csv``, the truth here, itself tested
in test_csv_reader.py and test_io_readers.py) for what exports hold: a units row, comments and a preamble, CRLF line
ends, ISO 8601 date-times, blank lines, a cut last line, a bad field beyond the first lines. What cannot be read so
(``;`` or tab separated, not UTF-8) is read whole."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from roadbank.io import LogError, csvtable, load_log
from roadbank.io.channels import default_channel_map
from roadbank.io.sources import WholeSource, open_source
from roadbank.io.stream import stream_log

N = 1500           # lines of data: several blocks of 7 and 500, more than csvtable.HEAD_LINES


@pytest.fixture(autouse=True)
def _stream_every_size(monkeypatch):
    monkeypatch.setattr(csvtable, "CSV_WHOLE_BYTES", 0)


def _rows(n: int = N, time=lambda k: f"{k / 100:.2f}") -> list[str]:
    """``n`` data lines of a 100 Hz drive in gentle turns: t, vx, ay, r, delta_f."""
    out = []
    for k in range(n):
        t = k / 100
        r = 0.05 * np.sin(0.4 * t)
        out.append(f"{time(k)},{15 + np.sin(0.1 * t):.6f},{15 * r + 0.1 * np.sin(0.05 * t):.6f},{r:.6f},"
                   f"{r / 5:.6f}")
    return out


HEADER = "t,vx,ay,r,delta_f"


def _write(tmp_path: Path, lines: list[str], end: str = "\n", newline: str = "\n", name: str = "log.csv") -> Path:
    p = tmp_path / name
    p.write_bytes((newline.join(lines) + end).encode())
    return p


VARIANTS = {
    "plain": lambda: [HEADER] + _rows(),
    "units row": lambda: [HEADER, "s,m/s,m/s^2,rad/s,rad"] + _rows(),
    "comments and a preamble": lambda: ["# exported", "Recorder: DEWE-43", "Date: 06.12.2026", HEADER] + _rows(),
    "blank lines": lambda: [HEADER] + [x if k % 97 else "" for k, x in enumerate(_rows())],
    "date-times": lambda: [HEADER] + _rows(time=lambda k: f"2026-12-06 10:{k // 6000:02d}:{(k // 100) % 60:02d}."
                                                      f"{k % 100:02d}0"),
    "quoted fields": lambda: [HEADER] + [f'"{x.split(",")[0]}",{x.split(",", 1)[1]}' for x in _rows()],
    "times of day past midnight": lambda: [HEADER] + _rows(time=_clock),
}


def _clock(k: int) -> str:
    """Line ``k``'s time of day, 100 Hz from 23:59:50 (past midnight after 10 s)."""
    t = (86_390.0 + k / 100) % 86_400.0
    return f"{int(t // 3600):02d}:{int(t % 3600 // 60):02d}:{t % 60:05.2f}"


@pytest.mark.parametrize("chunk", [7, 500])
@pytest.mark.parametrize("newline", ["\n", "\r\n"])
@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_streamed_is_the_whole_read(tmp_path, variant, newline, chunk):
    """Every variant, LF or CRLF: the chunks end to end are the whole read's signals, bit for bit, with the same
    warnings (a preamble said once), and the source is the streamed one."""
    p = _write(tmp_path, VARIANTS[variant](), newline=newline)
    assert not isinstance(open_source(p, "csv", default_channel_map(), chunk), WholeSource)
    whole = load_log(p)
    chunks = list(stream_log(p, chunk_rows=chunk))
    assert len(chunks) > 1
    for k in ("t", "vx", "ay", "r", "delta_f"):
        assert np.array_equal(np.concatenate([getattr(c.signals, k) for c in chunks]), getattr(whole.signals, k),
                              equal_nan=True), k
    assert [w for c in chunks for w in c.warnings] == whole.warnings


@pytest.mark.parametrize("chunk", [7, 500])
def test_a_cut_last_line_is_left_out_alike(tmp_path, chunk):
    """No final newline: the last line is left out, naming its line number, streamed as read whole."""
    lines = [HEADER] + _rows()
    p = _write(tmp_path, lines[:-1] + [lines[-1][:-3]], end="")
    whole = load_log(p)
    chunks = list(stream_log(p, chunk_rows=chunk))
    assert np.array_equal(np.concatenate([c.signals.t for c in chunks]), whole.signals.t)
    said = [w for c in chunks for w in c.warnings if "was left out" in w]
    assert said == [w for w in whole.warnings if "was left out" in w] and f"line {N + 1} was left out" in said[0]


@pytest.mark.parametrize("damage, message", [
    (lambda x: x + ",9", r"line 1201 has 6 field"),
    (lambda x: x.split(",", 1)[0] + ",1.2.3," + x.split(",", 2)[2],
     r"'vx'\): non-numeric value '1\.2\.3' at line 1201"),
    (lambda x: "# a comment", r"line 1201 is a comment"),
])
@pytest.mark.parametrize("chunk", [7, 500])
def test_an_error_beyond_the_head_names_its_line_alike(tmp_path, damage, message, chunk):
    """A bad line 1201 (a field too many, a field that is no number, a comment after the header): the same error,
    naming the file and line 1201, streamed as read whole."""
    lines = [HEADER] + _rows()
    lines[1200] = damage(lines[1200])
    p = _write(tmp_path, lines)
    with pytest.raises(LogError, match=message) as whole:
        load_log(p)
    with pytest.raises(LogError, match=message) as streamed:
        list(stream_log(p, chunk_rows=chunk))
    assert str(streamed.value) == str(whole.value)


def test_date_times_that_turn_into_numbers_are_refused(tmp_path):
    """A time column of date-times in its first lines and numbers later: refused naming the column, streamed as
    read whole (there: a field that is no number)."""
    rows = _rows(time=lambda k: f"2026-12-06 10:00:{k // 100:02d}.{k % 100:02d}0" if k < 1000 else f"{k / 100}")
    p = _write(tmp_path, [HEADER] + rows)
    with pytest.raises(LogError, match="'t'"):
        load_log(p)
    with pytest.raises(LogError, match="column 't' holds date-times in its first lines but not in lines"):
        list(stream_log(p, chunk_rows=500))


@pytest.mark.parametrize("case", ["semicolons", "latin-1", "short", "small"])
def test_what_is_read_whole(tmp_path, monkeypatch, case):
    """``;``-separated (its decimal commas are decided over a whole column), not UTF-8 (read as Windows-1252 after
    a look at the whole file), no more lines than the head, or no bigger than CSV_WHOLE_BYTES: read whole, one
    source for the whole file, whatever the chunk size."""
    lines = [HEADER] + _rows()
    if case == "semicolons":
        lines = [x.replace(",", ";") for x in lines]
    if case == "short":
        lines = lines[:csvtable.HEAD_LINES - 5]
    p = _write(tmp_path, lines)
    if case == "latin-1":
        p.write_bytes(p.read_bytes().replace(b"t,vx", "t\xb0,vx".encode("cp1252"), 1))
    if case == "small":
        monkeypatch.setattr(csvtable, "CSV_WHOLE_BYTES", p.stat().st_size)
    cmap = default_channel_map()
    assert isinstance(open_source(p, "csv", cmap, 7), WholeSource)


def test_times_of_day_are_seconds_from_the_first_midnight(tmp_path):
    """Independent truth: the same drive with its time column written as seconds (86 390.00, 86 390.01, ... past
    86 400) and as times of day (23:59:50.00 ... 00:00:04.99): the same signals, read whole and streamed; a time of
    day that is none (24:00:01) is refused naming its line."""
    numbers = _write(tmp_path, [HEADER] + _rows(time=lambda k: f"{86_390.0 + k / 100:.2f}"), name="s.csv")
    clock = _write(tmp_path, [HEADER] + _rows(time=_clock), name="clock.csv")
    want = load_log(numbers)
    for got in (load_log(clock), list(stream_log(clock, chunk_rows=500))):
        chunks = got if isinstance(got, list) else [got]
        for k in ("t", "ay"):
            np.testing.assert_allclose(np.concatenate([getattr(c.signals, k) for c in chunks]),
                                       getattr(want.signals, k), rtol=0, atol=1e-9, err_msg=k)
    assert want.signals.t[-1] > 86_400.0
    lines = [HEADER] + _rows(time=_clock)
    lines[700] = "24:00:01," + lines[700].split(",", 1)[1]
    with pytest.raises(LogError, match="'24:00:01' at line 701 is no time of day"):
        load_log(_write(tmp_path, lines, name="bad.csv"))


@pytest.mark.parametrize("block", [7, 16, 64, 1 << 20])
def test_the_byte_pass_counts_lines_as_splitlines(tmp_path, monkeypatch, block):
    """Independent truth, str.splitlines: the byte pass's line count, last line and final break agree on files
    whose blocks end anywhere (mid-line, between CR and LF, in a two-byte character), with LF, CRLF and CR ends,
    with and without a final break."""
    rng = np.random.default_rng(block)
    monkeypatch.setattr(csvtable, "SCAN_BYTES", block)
    checked = 0
    for case in range(40):
        n = int(rng.integers(3, 40))
        lines = ["é" * int(rng.integers(0, 3)) + "x" * int(rng.integers(0, 30)) for _ in range(n)]
        newline = ["\n", "\r\n", "\r"][case % 3]
        text = newline.join(lines) + (newline if case % 2 else "")
        p = tmp_path / f"f{case}.csv"
        p.write_bytes(text.encode())
        got = csvtable._scan(p)
        want = text.splitlines()
        if got is None:             # only where the last two blocks hold no whole line
            data = p.read_bytes()
            last = (len(data) - 1) // block * block             # where the last block starts
            assert len(data[max(last - block, 0):].decode("utf-8", "replace").splitlines()) < 2
            continue
        assert (got.lines, got.last, got.ends_newline) == (len(want), want[-1], text.endswith(("\n", "\r"))), case
        checked += 1
    assert checked >= (30 if block >= 64 else 5)
