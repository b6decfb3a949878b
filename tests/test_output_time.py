"""What the `t` column of `roadbank estimate`'s table is, format by format (docs/io.md, "the output table"): the log's
own clock as read, never re-based by the command. Each log is written here with stamps whose origin is known (a clock
starting at 1000 s, ISO date-times of a known epoch, an MDF4 file whose header names its start time), or is a shared
KITTI drive read against its own timestamps.txt; the table's `t` is checked against those stamps."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import main

EPOCH = 1_700_000_000.0
KITTI_0070 = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "kitti-oxts" / "2011_09_26_drive_0070"


@pytest.fixture(scope="module")
def drive():
    """12 s of a simulated drive: stamps from 0 (s) and the four ESP channels (SI, ISO)."""
    from roadbank.sim import run_scenario
    s = run_scenario("bank-lane-change", seed=2).signals
    n = 1200
    return s.t[:n] - s.t[0], {"vx": s.vx[:n], "ay": s.ay[:n], "r": s.r[:n], "delta_f": s.delta_f[:n]}


def _csv(path: Path, stamps: list[str], cols: dict) -> Path:
    with open(path, "w") as fh:
        fh.write(",".join(["t", *cols]) + "\n")
        for i, stamp in enumerate(stamps):
            fh.write(",".join([stamp, *(repr(float(c[i])) for c in cols.values())]) + "\n")
    return path


def _estimate_t(log: Path, tmp_path: Path) -> np.ndarray:
    out = tmp_path / (log.name + ".bank.parquet")
    res = CliRunner().invoke(main, ["estimate", str(log), "-o", str(out), "-e", "kinematic"])
    assert res.exit_code == 0, res.output
    return pq.read_table(out).column("t").to_numpy()


def test_a_numeric_time_column_is_written_as_it_is(tmp_path, drive):
    t, cols = drive
    got = _estimate_t(_csv(tmp_path / "num.csv", [repr(float(1000.0 + x)) for x in t], cols), tmp_path)
    np.testing.assert_array_equal(got, 1000.0 + t)


def test_iso_date_times_are_seconds_since_the_epoch(tmp_path, drive):
    t, cols = drive
    stamps = [dt.datetime.fromtimestamp(EPOCH + x, dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S.%f") for x in t]
    got = _estimate_t(_csv(tmp_path / "iso.csv", stamps, cols), tmp_path)
    np.testing.assert_allclose(got - EPOCH, t, rtol=0, atol=2e-6)


def test_an_mdf4_signal_file_is_its_master_time_from_the_file_start(tmp_path, drive):
    """The master time as stored: seconds from the header's start time, which is not added (unlike MDF4 bus
    logging, whose frames are made absolute with it)."""
    asammdf = pytest.importorskip("asammdf")
    t, cols = drive
    mdf = asammdf.MDF(version="4.10")
    mdf.header.start_time = dt.datetime.fromtimestamp(EPOCH, dt.timezone.utc)
    mdf.append([asammdf.Signal(np.asarray(v, dtype=np.float64), 5.0 + t, name=k) for k, v in cols.items()])
    mdf.save(tmp_path / "sig.mf4", overwrite=True)
    got = _estimate_t(tmp_path / "sig.mf4", tmp_path)
    np.testing.assert_allclose(got, 5.0 + t, rtol=0, atol=1e-9)


@pytest.mark.skipif(not KITTI_0070.is_dir(), reason="../shared/data/kitti-oxts is not here")
def test_a_kitti_drive_is_seconds_from_its_first_frame(tmp_path):
    """KITTI: seconds from the drive's first frame, whose UTC stamp is the log's metadata time_origin; with it the
    table's t gives back every frame's stamp in timestamps.txt."""
    from roadbank.io import load_log
    lines = (KITTI_0070 / "oxts" / "timestamps.txt").read_text().split()
    stamps = [dt.datetime.fromisoformat(f"{d} {h[:15]}").replace(tzinfo=dt.timezone.utc).timestamp()
              for d, h in zip(lines[::2], lines[1::2])]
    got = _estimate_t(KITTI_0070, tmp_path)
    origin = load_log(KITTI_0070).metadata["time_origin"]
    assert origin.startswith(" ".join(lines[:2])[:26])
    np.testing.assert_allclose(got + stamps[0], stamps, rtol=0, atol=2e-6)
