"""The CSV reader's two paths: a plain file parsed by numpy in C gives what the general (csv module,
field by field ``float()``) path gives, bit for bit; anything else takes the general path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from roadbank.io import LogError
from roadbank.io.csvtable import _plain_csv, read_csv


def _values(rng, n):
    """Numbers as loggers write them: shortest repr, fixed decimals, exponents, integers, signs."""
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-12, 12, n)
    kinds = rng.integers(0, 5, n)
    return [repr(float(v)) if k == 0 else f"{v:.6f}" if k == 1 else f"{v:.3e}" if k == 2
            else str(int(v)) if k == 3 else f"{v:+.9g}" for v, k in zip(x, kinds)]


@pytest.mark.parametrize("delim", [",", ";", "\t"])
@pytest.mark.parametrize("quoted_header, newline", [(False, "\n"), (True, "\r\n")])
def test_a_plain_file_reads_as_the_general_path_reads_it(tmp_path, delim, quoted_header, newline):
    rng = np.random.default_rng(7)
    names = ["t", "vx", "ay", "r", "gear", "delta_f"]
    n = 3000
    cols = {c: _values(rng, n) for c in names}
    cols["gear"] = [str(int(g)) for g in rng.integers(1, 6, n)]
    head = delim.join(f'"{c}"' if quoted_header else c for c in names)
    text = newline.join([head] + [delim.join(cols[c][i] for c in names) for i in range(n)]) + newline
    plain, general = tmp_path / "plain.csv", tmp_path / "general.csv"
    plain.write_text(text, newline="")
    general.write_text(text + newline, newline="")       # a blank last line: the general path
    wanted = {"t": "time", "vx": "speed", "ay": "lateral_acceleration", "r": "yaw_rate"}
    lines = text.splitlines()
    delim_found = max((",", ";", "\t"), key=lines[0].count)
    assert _plain_csv(plain, lines, delim_found, wanted, "delta") is not None
    assert _plain_csv(general, (text + newline).splitlines(), delim_found, wanted, "delta") is None
    a, b = read_csv(plain, wanted, prefix="delta"), read_csv(general, wanted, prefix="delta")
    assert a.names == b.names == names and list(a.data) == list(b.data) == ["t", "vx", "ay", "r", "delta_f"]
    assert list(a.rownums) == list(b.rownums) == list(range(2, n + 2)) and a.row_label == b.row_label == "line"
    for c in a.data:
        np.testing.assert_array_equal(a.data[c].view(np.int64), b.data[c].view(np.int64))   # the same bits
        np.testing.assert_array_equal(a.data[c], np.array([float(v) for v in cols[c]]))


@pytest.mark.parametrize("body, problem", [
    ("1,2\n3,NA\n", None),                             # a missing-value token: NaN, by the general path
    ("1,2\n\n3,4\n", None),                            # a blank line: skipped, the line numbers kept
    ('1,"2"\n3,4\n', None),                            # quoted fields
    ("1,2\n3\n", "line 3 has 1 field"),                # a short line: named
    ("1,2\n3,x\n", "non-numeric value 'x' at line 3"),  # a bad number: named
])
def test_other_files_take_the_general_path_and_its_messages(tmp_path, body, problem):
    p = Path(tmp_path) / "f.csv"
    p.write_text("t,vx\n" + body)
    lines = p.read_text().splitlines()
    assert _plain_csv(p, lines, ",", {"t": "time", "vx": "speed"}, None) is None
    if problem is None:
        got = read_csv(p, {"t": "time", "vx": "speed"})
        assert len(got.data["t"]) == len(got.rownums) and np.isnan(got.data["vx"]).sum() == ("NA" in body)
    else:
        with pytest.raises(LogError, match=problem):
            read_csv(p, {"t": "time", "vx": "speed"})
