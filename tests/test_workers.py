"""``validate`` and ``map`` on Dask workers: the same report, JSON and map as in one process, a bad
drive or log reported while the others go on, a failed task failing only its own drives or logs,
and the merge of per-log bank maps against one map of all the samples."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.mapping import BankMap, LocalProjection, map_logs
from roadbank.mapping import build as map_build

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
KITTI = DATA / "kitti-oxts"
COMMA = DATA / "comma2k19-example"
needs_kitti = pytest.mark.skipif(not any(KITTI.glob("*/oxts")), reason=f"KITTI oxts drives absent at {KITTI}")
NAMES = "kinematic,pio-modified,pif-modified,uio"        # uio reads the steering angle KITTI lacks
pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def scheduler():
    """Two threaded workers in this process (the tasks still go through Dask's serialisation)."""
    import distributed
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as c:
        yield c.scheduler_address


def _invoke_in(tmp_path, name, args):
    """Run the CLI in its own directory ``tmp_path/name`` (so that relative outputs, and the command
    lines written into the reports, are the same between runs)."""
    d = tmp_path / name
    d.mkdir()
    old = os.getcwd()
    os.chdir(d)
    try:
        res = CliRunner().invoke(main, args)
    finally:
        os.chdir(old)
    out = d / "out"
    return res, ({p.name: p.read_bytes() for p in out.iterdir()} if out.is_dir() else {})


# ---------------------------------------------------------------- validate
@pytest.mark.slow
@needs_kitti
def test_validate_kitti_on_two_workers_equals_one_process(tmp_path):
    args = ["validate", "kitti", str(KITTI), "--json", "-e", NAMES, "-o", "out/real-data.md"]
    one, files1 = _invoke_in(tmp_path, "one", args)
    two, files2 = _invoke_in(tmp_path, "two", args + ["--workers", "2"])
    assert one.exit_code == 0 and two.exit_code == 0, (one.output, two.output)
    assert len(json.loads(one.stdout)["drives"]) == 2
    assert two.stdout == one.stdout                                  # the JSON, number for number
    assert files2["real-data.md"] == files1["real-data.md"]          # the report
    assert sorted(files2) == sorted(files1) and len(files1) == 3     # the report and one PNG per drive


def _bad_drive(tmp_path):
    bad = tmp_path / "2011_01_01_drive_0009_sync" / "oxts"
    (bad / "data").mkdir(parents=True)
    (bad / "timestamps.txt").write_text("2011-01-01 12:00:00.0\nnot a time\n")
    return bad.parent


@pytest.mark.slow
@needs_kitti
def test_bad_drive_on_workers_is_reported_and_the_others_scored(tmp_path):
    good = sorted(KITTI.glob("*/oxts"))
    args = ["validate", "kitti", str(_bad_drive(tmp_path)), *(str(g.parent) for g in good), "--json",
            "--no-sensitivity", "-e", "kinematic"]
    one = CliRunner().invoke(main, args)
    two = CliRunner().invoke(main, args + ["--workers", "2"])
    assert two.exit_code == 1 and "Traceback" not in two.output
    data = json.loads(two.stdout)
    assert list(data["drives"]) == [g.parent.name for g in good]
    assert len(data["errors"]) == 1 and "timestamps.txt: line 2: unparsable time stamp" in data["errors"][0]
    assert two.stdout == one.stdout


@needs_kitti
def test_a_failed_drive_task_fails_that_drive_only(scheduler, monkeypatch):
    from roadbank.fleet.cluster import open_pool
    from roadbank.validation import kitti

    real = kitti._drive_outcome

    def dies_on_0070(path, *args):
        if "0070" in str(path):
            raise MemoryError("worker ran out of memory")
        return real(path, *args)
    monkeypatch.setattr(kitti, "_drive_outcome", dies_on_0070)
    with open_pool(scheduler=scheduler) as pool:
        v = kitti.validate_kitti([KITTI], names=["kinematic"], sensitivity=False, pool=pool)
    assert [d.label for d in v.drives] == ["2011_10_03_drive_0047"]
    assert len(v.errors) == 1 and "2011_09_26_drive_0070" in v.errors[0]
    assert "worker failed: MemoryError: worker ran out of memory" in v.errors[0]
    alone = kitti.validate_kitti([KITTI / "2011_10_03_drive_0047"], names=["kinematic"], sensitivity=False)
    assert v.pooled == alone.pooled                              # pooled over the drive that was scored


@pytest.mark.slow
@needs_kitti
@pytest.mark.skipif(not COMMA.is_dir(), reason=f"comma2k19 example segment absent at {COMMA}")
def test_validate_all_on_a_scheduler_equals_one_process(tmp_path, scheduler):
    data = tmp_path / "data"
    data.mkdir()
    (data / COMMA.name).symlink_to(COMMA.resolve())
    drive = next(KITTI.glob("*/oxts")).parent
    (data / drive.name).symlink_to(drive.resolve())
    args = ["validate", "all", str(data), "-o", "out/real-data.md", "--no-jitter"]
    one, files1 = _invoke_in(tmp_path, "one", args)
    two, files2 = _invoke_in(tmp_path, "two", args + ["--scheduler", scheduler])
    assert one.exit_code == 0 and two.exit_code == 0, (one.output, two.output)
    assert "## KITTI raw drives" in files1["real-data.md"].decode() and "comma2k19" in files1["real-data.md"].decode()
    assert files2["real-data.md"] == files1["real-data.md"]


def test_a_scheduler_that_cannot_be_reached_is_one_line(tmp_path, monkeypatch):
    from roadbank.campaign import execute

    def unreachable(scheduler, workers, connect_timeout=20.0):
        raise ConnectionError(f"cannot connect to the Dask scheduler at {scheduler}: refused")
    monkeypatch.setattr(execute, "open_client", unreachable)
    _, paths = _map_logs(tmp_path, n=1)
    data = paths[0].parent
    (data / "2011_01_01_drive_0001_sync" / "oxts" / "data").mkdir(parents=True)
    (data / "2011_01_01_drive_0001_sync" / "oxts" / "timestamps.txt").write_text("2011-01-01 12:00:00.0\n")
    for args in (["validate", "kitti", str(tmp_path)], ["validate", "comma2k19", str(tmp_path)],
                 ["validate", "all", str(data), "-o", str(tmp_path / "r.md")],
                 ["map", str(paths[0]), "--channels", str(tmp_path / "m.toml"), "-o", str(tmp_path / "m.parquet")]):
        res = CliRunner().invoke(main, args + ["--scheduler", "tcp://127.0.0.1:9"])
        assert res.exit_code == 1 and "Traceback" not in res.output, args
        assert "error: cannot connect to the Dask scheduler at tcp://127.0.0.1:9" in res.output, args
    res = CliRunner().invoke(main, ["map", str(tmp_path), "-o", str(tmp_path / "m.parquet"), "--workers", "0"])
    assert res.exit_code == 2 and "must be >= 1" in res.output


# ---------------------------------------------------------------- map
PROJ = LocalProjection(48.0, 11.0)
from test_mapping import MAP_TOML  # noqa: E402  (the map tests' channel map)


def _map_logs(tmp_path, n=6, origin=PROJ):
    """``n`` passes along one east-west road (alternating directions, each its own noise), banked
    2 deg for e < 150 m and 4 deg beyond (left side up eastbound), a corrupt file and a log without
    positions among them."""
    rng = np.random.default_rng(1)
    d = tmp_path / "logs"
    d.mkdir()
    paths = []
    for i in range(n):
        k = 1500 + 37 * i
        t = np.arange(k) * 0.01
        v = 15.0 + i
        east = i % 2 == 0
        e = 5.0 + v * t if east else 5.0 + v * t[-1] - v * t
        bank = np.radians(np.where(e < 150.0, 2.0, 4.0)) * (1.0 if east else -1.0)
        ay = 9.81 * np.sin(bank) + (0.03 + 0.01 * i) * rng.standard_normal(k)
        lat, lon = origin.to_latlon(e, np.full(k, 3.0 + 0.5 * i))
        p = d / f"log{i:02d}.parquet"
        pq.write_table(pa.table({"t": t, "vx": np.full(k, v), "ay": ay, "r": np.zeros(k), "delta_f": np.zeros(k),
                                 "lat": lat, "lon": lon}), p)
        paths.append(p)
    (d / "log90-corrupt.parquet").write_bytes(b"PAR1 truncated")
    pq.write_table(pa.table({"t": np.arange(600) * 0.01, "vx": np.full(600, 20.0), "ay": np.zeros(600),
                             "r": np.zeros(600), "delta_f": np.zeros(600)}), d / "log91-nogps.parquet")
    (tmp_path / "m.toml").write_text(MAP_TOML)
    return d, paths


def test_merge_of_per_log_maps_equals_one_map_of_all_samples():
    rng = np.random.default_rng(2)
    passes = []
    for i in range(3):
        e = np.linspace(0.5, 120.0, 400) + i
        lat, lon = PROJ.to_latlon(e, np.full(400, 4.0 + i))
        passes.append((lat, lon, rng.normal(0.03, 0.01, 400), rng.random(400) > 0.2))
    whole = BankMap(PROJ, 10.0, 4)
    parts = [BankMap(PROJ, 10.0, 4) for _ in passes]
    for k, (lat, lon, pb, ok) in enumerate(passes):
        for c in (slice(0, 150), slice(150, None)):                          # a log in two chunks
            whole.add(lat[c], lon[c], pb[c], ok[c], log_id=k)
            parts[k].add(lat[c], lon[c], pb[c], ok[c], log_id=k)
    merged = BankMap(PROJ, 10.0, 4)
    for p in parts:
        assert merged.merge(p) is merged
    a, b = whole.table(), merged.table()
    for col in ("ix", "iy", "sector", "count", "logs"):
        np.testing.assert_array_equal(a[col], b[col])
    assert a["logs"].max() == 3
    for col in ("bank_mean_deg", "bank_std_deg", "bank_min_deg", "bank_max_deg", "lat_deg", "lon_deg"):
        np.testing.assert_allclose(a[col], b[col], rtol=1e-12, atol=1e-12)
    assert len(parts[0]) == len(parts[0].table()["ix"])                 # merging left the parts alone
    for other in (BankMap(LocalProjection(48.0, 11.01)), BankMap(PROJ, 5.0), BankMap(PROJ, sectors=1)):
        with pytest.raises(ValueError, match="cannot merge a map"):
            merged.merge(other)


def _table(path):
    return pq.read_table(path)


@pytest.mark.slow
def test_map_on_two_workers_equals_one_process(tmp_path):
    d, paths = _map_logs(tmp_path)
    base = ["map", str(d), "--channels", str(tmp_path / "m.toml"), "--chunk-rows", "400"]
    one = CliRunner().invoke(main, base + ["-o", str(tmp_path / "one.parquet")])
    two = CliRunner().invoke(main, base + ["-o", str(tmp_path / "two.parquet"), "--workers", "2"])
    for r in (one, two):
        assert r.exit_code == 1 and "Traceback" not in r.output              # the two bad logs
        assert "log90-corrupt.parquet" in r.output and "log91-nogps.parquet" in r.output
    t1, t2 = _table(tmp_path / "one.parquet"), _table(tmp_path / "two.parquet")
    assert t2.equals(t1) and t1.schema.metadata == t2.schema.metadata       # cell for cell, bit for bit
    tab = t1.to_pydict()
    assert max(tab["logs"]) == 3 and set(tab["sector"]) == {1, 3}           # three passes each way
    assert tab["lat_deg"][0] == pytest.approx(PROJ.to_latlon(5.0, 5.0)[0], abs=1e-9)    # origin: 48, 11


def test_map_on_a_scheduler_equals_one_process_with_the_guess_corrected(tmp_path, scheduler, monkeypatch):
    from roadbank.fleet.cluster import open_pool

    _, paths = _map_logs(tmp_path, n=4)
    kw = dict(estimator="kinematic", chunk_rows=500, channels=tmp_path / "m.toml")
    from roadbank.io import read_channel_map
    kw["channels"] = read_channel_map(kw["channels"])
    ref, recs_ref = map_logs(paths, **kw)
    with open_pool(scheduler=scheduler) as pool:
        got, recs = map_logs(paths, pool=pool, **kw)
        # a wrong first guess of the origin (as when the log that gave it fails before mapping it):
        # the logs are mapped again on the origin the logs reach first
        monkeypatch.setattr(map_build, "_first_fix", lambda *a: LocalProjection(47.0, 10.0))
        again, _ = map_logs(paths, pool=pool, **kw)
        fixed, _ = map_logs(paths, pool=pool, origin=(48.5, 11.5), **kw)
    ref_fixed, _ = map_logs(paths, origin=(48.5, 11.5), **kw)
    assert [r.__dict__ for r in recs] == [r.__dict__ for r in recs_ref]
    for m, want in ((got, ref), (again, ref), (fixed, ref_fixed)):
        assert m.projection == want.projection
        for col, v in want.table().items():
            np.testing.assert_array_equal(m.table()[col], v, err_msg=col)
    assert ref.projection == PROJ and fixed.projection == LocalProjection(48.5, 11.5)


def test_a_failed_map_task_fails_its_logs_only(tmp_path, scheduler, monkeypatch):
    from roadbank.fleet.cluster import open_pool
    from roadbank.io import read_channel_map

    _, paths = _map_logs(tmp_path, n=4)
    kw = dict(estimator="kinematic", channels=read_channel_map(tmp_path / "m.toml"), origin=(48.0, 11.0))
    real = map_build._map_batch

    def dies_on_log01(jobs, settings, projection):
        if any(p.name == "log01.parquet" for _, p in jobs):
            raise MemoryError("worker ran out of memory")
        return real(jobs, settings, projection)
    monkeypatch.setattr(map_build, "_map_batch", dies_on_log01)
    with open_pool(scheduler=scheduler) as pool:
        got, recs = map_logs(paths, pool=pool, **kw)
    bad = [r for r in recs if r.status != "ok"]
    assert [r.log for r in bad] == [str(paths[1])]                    # 4 logs, 2 workers: one per task
    assert "worker failed: MemoryError" in bad[0].error and bad[0].mapped == 0
    want, _ = map_logs([p for p in paths if p != paths[1]], **kw)
    a, b = got.table(), want.table()
    np.testing.assert_array_equal(a["count"], b["count"])
    np.testing.assert_allclose(a["bank_mean_deg"], b["bank_mean_deg"], rtol=1e-12)
    assert math.isclose(sum(a["count"]), sum(r.mapped for r in recs))
