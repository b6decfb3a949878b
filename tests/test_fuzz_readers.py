"""Fuzzing the log readers (hypothesis): corrupt bytes give a LogError or a valid Log, never a crash.

Seeds are well-formed CSV and Parquet logs in roadbank's own columns; hypothesis
truncates them, overwrites byte runs, inserts bytes, or writes arbitrary bytes.
"""

from __future__ import annotations

import io
import tempfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from roadbank.io import LogError, load_log


def _columns(n=60):
    t = np.arange(n) * 0.01
    return {"t": t, "vx": np.full(n, 20.0), "ay": 0.5 + 0.1 * np.sin(t), "r": 0.02 + 0.0 * t,
            "delta_f": 0.01 * np.cos(t)}


def _csv_bytes() -> bytes:
    c = _columns()
    buf = io.StringIO()
    buf.write(",".join(c) + "\n")
    for row in zip(*c.values()):
        buf.write(",".join(f"{v:.6g}" for v in row) + "\n")
    return buf.getvalue().encode()


def _parquet_bytes() -> bytes:
    sink = io.BytesIO()
    pq.write_table(pa.table({k: pa.array(v) for k, v in _columns().items()}), sink)
    return sink.getvalue()


SEEDS = {".csv": _csv_bytes(), ".parquet": _parquet_bytes()}


@st.composite
def corrupted(draw, seed: bytes):
    data = bytearray(seed)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["truncate", "overwrite", "insert", "delete"]))
        if not data:
            break
        i = draw(st.integers(0, len(data) - 1))
        if kind == "truncate":
            data = data[:i]
        elif kind == "overwrite":
            chunk = draw(st.binary(min_size=1, max_size=16))
            data[i:i + len(chunk)] = chunk
        elif kind == "insert":
            data[i:i] = draw(st.binary(min_size=1, max_size=16))
        else:
            del data[i:i + draw(st.integers(1, 32))]
    return bytes(data)


def _load(suffix: str, data: bytes):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"log{suffix}"
        p.write_bytes(data)
        try:
            log = load_log(p)
        except LogError as exc:
            assert str(p) in str(exc)           # the message names the file
            return None
    assert len(log.signals) >= 2
    assert np.all(np.diff(log.signals.t) > 0)
    return log


def test_seeds_are_readable():
    for suffix, data in SEEDS.items():
        assert _load(suffix, data) is not None


FUZZ = settings(deadline=None, max_examples=150, suppress_health_check=[HealthCheck.too_slow])


@FUZZ
@given(data=corrupted(SEEDS[".csv"]))
def test_corrupt_csv_never_crashes(data):
    _load(".csv", data)


@FUZZ
@given(data=corrupted(SEEDS[".parquet"]))
def test_corrupt_parquet_never_crashes(data):
    _load(".parquet", data)


@settings(FUZZ, max_examples=60)
@given(data=st.binary(max_size=512), suffix=st.sampled_from([".csv", ".parquet"]))
def test_arbitrary_bytes_never_crash(data, suffix):
    _load(suffix, data)
