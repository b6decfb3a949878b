"""Bank maps: grid mechanics on hand-made drives, a simulated drive over the banked test track, comma2k19.

Truths: hand-made positions and banks (exact cell means and counts); the
simulator's truth bank at the same samples, attached to positions rebuilt from
the road geometry (the map of the estimate must recover it per cell); on
comma2k19, the pose's roll (device roll = bank + body roll + a mounting offset).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from roadbank.cli import main
from roadbank.defaults import MAP_ESTIMATOR
from roadbank.vehicle import for_log
from roadbank.mapping import BankMap, LocalProjection, map_logs
from roadbank.mapping.geo import EARTH_RADIUS

COMMA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "comma2k19-example"


def _haversine(lat1, lon1, lat2, lon2):
    p1, p2 = np.radians(lat1), np.radians(lat2)
    a = np.sin((p2 - p1) / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(np.radians(lon2 - lon1) / 2) ** 2
    return 2 * EARTH_RADIUS * np.arcsin(np.sqrt(a))


def test_projection_round_trip_and_scale():
    proj = LocalProjection(48.1, 11.5)
    lat, lon = proj.to_latlon(np.array([0.0, 3000.0, -2000.0]), np.array([0.0, -1500.0, 4000.0]))
    e, n = proj.to_en(lat, lon)
    np.testing.assert_allclose(e, [0.0, 3000.0, -2000.0], atol=1e-6)
    np.testing.assert_allclose(n, [0.0, -1500.0, 4000.0], atol=1e-6)
    d = _haversine(lat[0], lon[0], lat[1:], lon[1:])
    np.testing.assert_allclose(d, np.hypot(e[1:], n[1:]), rtol=1e-3)      # < 0.1 % within a few km


def _pass(proj, e_from, e_to, north, v=20.0, rate=100.0):
    e = np.arange(e_from, e_to, np.sign(e_to - e_from) * v / rate)
    return proj.to_latlon(e, np.full(len(e), north)), e


def test_cells_sectors_and_outputs(tmp_path):
    """An east-west road, driven both ways: the bank's sign follows the direction, sectors keep them apart."""
    proj = LocalProjection(48.0, 11.0)
    bmap = BankMap(proj, cell_m=10.0, sectors=4)
    (lat_e, lon_e), e_e = _pass(proj, 0.5, 199.5, 5.0)             # eastbound, in cells iy = 0
    bank_e = np.where(e_e < 100.0, math.radians(3.0), math.radians(5.0))
    valid = np.ones(len(e_e), bool)
    valid[::7] = False                                              # invalid samples are not mapped
    assert bmap.add(lat_e, lon_e, bank_e, valid, log_id="east") == valid[25:-25].sum()
    (lat_w, lon_w), e_w = _pass(proj, 199.5, 0.5, 5.0)             # westbound on the same cells
    bmap.add(lat_w, lon_w, np.where(e_w < 100.0, math.radians(-3.0), math.radians(-5.0)),
             np.ones(len(e_w), bool), log_id="west")
    tab = bmap.table()
    east, west = tab["sector"] == 1, tab["sector"] == 3
    assert set(tab["sector"]) == {1, 3} and set(tab["iy"]) == {0}
    for sel, sign in ((east, 1.0), (west, -1.0)):
        ix = tab["ix"][sel]
        want = sign * np.where(ix < 10, 3.0, 5.0)
        np.testing.assert_allclose(tab["bank_mean_deg"][sel], want, atol=1e-9)
        np.testing.assert_allclose(tab["bank_std_deg"][sel], 0.0, atol=1e-6)
        assert np.all(tab["logs"][sel] == 1)
    # counts: samples of the pass inside each cell (minus the course's 25-sample ends and the invalid ones)
    idx = np.arange(len(e_e))
    inner = (idx >= 25) & (idx < len(e_e) - 25) & valid
    for ix, cnt in zip(tab["ix"][east], tab["count"][east]):
        assert cnt == np.sum(inner & (np.floor(e_e / 10.0) == ix))
    np.testing.assert_allclose(tab["lat_deg"], proj.to_latlon(0.0, 5.0)[0], atol=1e-12)   # cell centres
    # one sector: both directions averaged, the signs cancel
    both = BankMap(proj, sectors=1)
    both.add(lat_e, lon_e, bank_e, np.ones(len(e_e), bool))
    both.add(lat_w, lon_w, -np.where(e_w < 100.0, math.radians(3.0), math.radians(5.0)), np.ones(len(e_w), bool))
    assert np.max(np.abs(both.table()["bank_mean_deg"])) < 0.5
    # outputs
    bmap.write_parquet(tmp_path / "m.parquet", {"estimator": "x"})
    meta = pq.read_schema(tmp_path / "m.parquet").metadata
    assert meta[b"cell_m"] == b"10.0" and meta[b"origin_lat_deg"] == b"48.0" and meta[b"estimator"] == b"x"
    gj = json.loads(bmap.write_geojson(tmp_path / "m.geojson").read_text())
    assert len(gj["features"]) == len(tab["ix"])
    ring = np.array(gj["features"][0]["geometry"]["coordinates"][0])
    e, n = proj.to_en(ring[:, 1], ring[:, 0])
    assert np.ptp(e) == pytest.approx(10.0, abs=1e-3) and np.ptp(n) == pytest.approx(10.0, abs=1e-3)
    assert bmap.plot(tmp_path / "m.png").stat().st_size > 1000


MAP_TOML = """
[channels]
time = { column = "t", unit = "s" }
speed = { column = "vx", unit = "m/s" }
lateral_acceleration = { column = "ay", unit = "m/s^2" }
yaw_rate = { column = "r", unit = "rad/s" }
road_wheel_angle = { column = "delta_f", unit = "rad" }
latitude = { column = "lat", unit = "deg" }
longitude = { column = "lon", unit = "deg" }
"""


def test_simulated_drive_recovers_the_tracks_bank_per_cell(tmp_path):
    """track-lane-change: lanes banked 20 and 30 deg in the curve, then the flat straight."""
    from roadbank import estimators
    from roadbank.mapping.simulated import run_positions
    from roadbank.sim import SCENARIOS, run_scenario

    res = run_scenario("track-lane-change", seed=1)
    proj = LocalProjection(48.0, 11.0)
    lat, lon = run_positions(res, SCENARIOS["track-lane-change"].road, proj)
    e, n = proj.to_en(lat, lon)
    step = np.hypot(np.diff(e), np.diff(n)) / np.diff(res.signals.t)
    np.testing.assert_allclose(step, res.truth.vx[1:], rtol=2e-3)     # positions move at the car's speed
    cols = dict(res.table(), lat=lat, lon=lon)
    pq.write_table(pa.table(cols), tmp_path / "drive.parquet")
    (tmp_path / "m.toml").write_text(MAP_TOML)
    out = tmp_path / "bank_map.parquet"
    r = CliRunner().invoke(main, ["map", str(tmp_path / "drive.parquet"), "--channels", str(tmp_path / "m.toml"),
                                  "-e", "kinematic", "--origin", "48,11", "-o", str(out),
                                  "--geojson", str(tmp_path / "m.geojson"),
                                  "--png", str(tmp_path / "m.png")])
    assert r.exit_code == 0, r.output
    got = pq.read_table(out).to_pydict()
    # truth map: the simulator's bank at the samples the estimator flagged valid, same cells
    est = estimators.make("kinematic").run(res.signals)
    truth = BankMap(LocalProjection(48.0, 11.0))
    truth.add(lat, lon, res.truth.phi_b, est.valid)
    want = truth.table()
    np.testing.assert_array_equal(got["ix"], want["ix"])
    np.testing.assert_array_equal(got["count"], want["count"])
    full = np.asarray(got["count"]) >= 20
    err = np.asarray(got["bank_mean_deg"])[full] - want["bank_mean_deg"][full]
    assert np.sqrt(np.mean(err ** 2)) < 1.0 and np.max(np.abs(err)) < 2.5
    banks = want["bank_mean_deg"][full]
    assert banks.min() < 1.0 and banks.max() > 28.0           # the map spans the flat straight and lane 3


def test_default_map_estimator_is_the_smoother_and_removes_the_lane_change_lag(tmp_path):
    """bank-lane-change (flat and 14 deg lanes): mapped with the default estimator (kinematic-smoother,
    which on this quiet simulated log is the offline pif-smoother) against the simulator's truth per
    cell, and with the causal default PIF."""
    from roadbank.io.channels import read_channel_map
    from roadbank.vehicle import load_vehicle

    res, lat, lon = _drive_with_positions(tmp_path, "bank-lane-change", seed=1)
    proj = LocalProjection(48.0, 11.0)
    errs = {}
    suv = load_vehicle("suv-paper")                  # the simulated car, described
    for name in (None, "pif-modified"):
        kw = {} if name is None else {"estimator": name}
        bmap, recs = map_logs([tmp_path / "drive.parquet"], channels=read_channel_map(tmp_path / "m.toml"),
                              origin=(48.0, 11.0), vehicle=suv, **kw)
        assert recs[0].status == "ok"
        got = bmap.table()
        truth, every = BankMap(proj), BankMap(proj)
        built = for_log(name or MAP_ESTIMATOR, res.signals, vehicle=suv)      # as the map builds it for the log
        out = built.run(res.signals)
        truth.add(lat, lon, res.truth.phi_b, out.settled)         # the map takes settled samples
        every.add(lat, lon, res.truth.phi_b, out.valid)
        want = truth.table()
        np.testing.assert_array_equal(got["count"], want["count"])
        assert 0 < np.sum(every.table()["count"]) - np.sum(got["count"]) <= 100 * out.t.size / (out.t[-1] - out.t[0])
        full = np.asarray(got["count"]) >= 20
        errs[name] = np.asarray(got["bank_mean_deg"])[full] - want["bank_mean_deg"][full]
    rms = {k: float(np.sqrt(np.mean(e ** 2))) for k, e in errs.items()}
    assert rms[None] < 0.2 and np.max(np.abs(errs[None])) < 0.5, rms
    assert rms[None] < 0.5 * rms["pif-modified"], rms


@pytest.mark.skipif(not COMMA.is_dir(), reason="comma2k19 example segment not available")
def test_comma2k19_map_against_pose_roll():
    from roadbank.io import load_log

    bmap, recs = map_logs([COMMA], "kinematic")
    assert recs[0].status == "ok" and recs[0].mapped > 0.9 * recs[0].samples
    tab = bmap.table()
    assert 80 <= len(tab["ix"]) <= 200                     # ~1 km of highway in 10 m cells
    assert set(tab["sector"]) == {0}                       # northbound
    log = load_log(COMMA)
    ref = BankMap(bmap.projection)
    from roadbank import estimators
    ok = estimators.make("kinematic").run(log.signals).valid
    ref.add(log.extra["lat_deg"], log.extra["lon_deg"], log.reference_roll, ok)
    d = tab["bank_mean_deg"] - ref.table()["bank_mean_deg"]
    # the pose roll includes the phone's mounting offset (reference minus estimate about +0.56 deg,
    # docs/real-data.md): the map sits that far below it, and the rest is the kinematic estimate's noise
    assert d.mean() == pytest.approx(-0.56, abs=0.1) and np.sqrt(np.mean((d - d.mean()) ** 2)) < 0.4


def test_log_without_position_reported_others_mapped(tmp_path):
    t = np.arange(600) * 0.01
    cols = {"t": t, "vx": np.full(600, 20.0), "ay": np.full(600, 0.5), "r": np.zeros(600),
            "delta_f": np.zeros(600)}
    pq.write_table(pa.table(cols), tmp_path / "nogps.parquet")
    proj = LocalProjection(48.0, 11.0)
    lat, lon = proj.to_latlon(np.zeros(600), 20.0 * t)
    pq.write_table(pa.table(dict(cols, lat=lat, lon=lon)), tmp_path / "gps.parquet")
    (tmp_path / "m.toml").write_text(MAP_TOML)
    r = CliRunner().invoke(main, ["map", str(tmp_path), "--channels", str(tmp_path / "m.toml"), "-e", "kinematic",
                                  "-o", str(tmp_path / "out" / "map.parquet")])
    assert r.exit_code == 1 and "Traceback" not in r.output
    assert "nogps.parquet" in r.output and "lat" in r.output       # names the file and the missing column
    tab = pq.read_table(tmp_path / "out" / "map.parquet").to_pydict()
    from roadbank import Signals
    from roadbank.vehicle import for_log
    sig = Signals(t, cols["vx"], cols["ay"], cols["r"], cols["delta_f"])
    est = for_log("kinematic", sig).run(sig)        # no car given: the undescribed car's roll
    np.testing.assert_allclose(tab["bank_mean_deg"], np.degrees(est.phi_b[est.valid].mean()), atol=1e-9)
    assert sum(tab["count"]) == est.valid[25:-25].sum()        # all of the good log, but the course's ends


def _geodetic_to_ecef(lat_deg, lon_deg, h):
    """WGS-84 geodetic -> ECEF (m), the closed-form forward transform."""
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)
    la, lo = np.radians(lat_deg), np.radians(lon_deg)
    n = a / np.sqrt(1 - e2 * np.sin(la) ** 2)
    return ((n + h) * np.cos(la) * np.cos(lo), (n + h) * np.cos(la) * np.sin(lo), (n * (1 - e2) + h) * np.sin(la))


def test_ecef_position_channels(tmp_path):
    """ECEF positions (as comma2k19 records them) in any log: converted to lat/lon, also when streamed."""
    from roadbank.io import LogError, load_log
    from roadbank.io.stream import stream_log

    n = 3000
    t = np.arange(n) * 0.01
    lat = 37.72 + 1e-5 * np.arange(n)
    lon = -122.47 + 2e-6 * np.arange(n)
    x, y, z = _geodetic_to_ecef(lat, lon, 30.0)
    cols = {"t": t, "vx": np.full(n, 20.0), "ay": np.zeros(n), "r": np.zeros(n), "delta_f": np.zeros(n),
            "X": x / 1000.0, "Y": y / 1000.0, "Z": z / 1000.0}
    pq.write_table(pa.table(cols), tmp_path / "ecef.parquet")
    text = MAP_TOML.split("latitude")[0] + "\n".join(f'ecef_{c.lower()} = {{ column = "{c}", unit = "km" }}'
                                                     for c in "XYZ") + "\n"
    (tmp_path / "m.toml").write_text(text)
    log = load_log(tmp_path / "ecef.parquet", channels=tmp_path / "m.toml")
    np.testing.assert_allclose(log.extra["lat_deg"], lat, atol=1e-8)     # ~1 mm
    np.testing.assert_allclose(log.extra["lon_deg"], lon, atol=1e-8)
    chunks = list(stream_log(tmp_path / "ecef.parquet", channels=tmp_path / "m.toml", chunk_rows=700))
    np.testing.assert_array_equal(np.concatenate([c.extra["lat_deg"] for c in chunks]), log.extra["lat_deg"])
    (tmp_path / "bad.toml").write_text(text.replace('unit = "km"', 'unit = "m"'))
    with pytest.raises(LogError, match=r"ecef\.parquet: channel 'ecef_x' \(column 'X'\): median distance .* "
                                       r"not an ECEF position"):
        load_log(tmp_path / "ecef.parquet", channels=tmp_path / "bad.toml")


def test_designs_are_measured_on_the_same_span_whatever_the_chunk_size(tmp_path):
    """roadbank estimate and map design a log's estimator on the conditions of its first 60 s
    (ReadAhead.leading): the same for a log streamed in small chunks as in one chunk."""
    from roadbank.io.stream import ReadAhead, stream_log
    from roadbank.sim import run_scenario
    from roadbank.vehicle import DESIGN_SPAN_S, log_conditions

    res = run_scenario("track-lane1", seed=2)
    pq.write_table(pa.table(res.table()), tmp_path / "drive.parquet")
    conds = []
    for rows in (200, 1_000_000):
        chunks = ReadAhead(stream_log(tmp_path / "drive.parquet", chunk_rows=rows))
        first = next(chunks)
        span = chunks.leading(first.signals, DESIGN_SPAN_S)
        assert span.t[-1] - span.t[0] >= min(DESIGN_SPAN_S, res.signals.t[-1] - res.signals.t[0]) - 0.011
        conds.append(log_conditions(span))
        if rows < len(res.signals):                 # the chunks read ahead are still handed out
            assert len(next(chunks).signals) == rows
    assert conds[0] == conds[1]


@pytest.mark.parametrize("sizes", [[1000], [7, 13, 200, 1, 30, 749], [26] * 38 + [12], [50, 0, 950]])
def test_course_stream_equals_the_course_of_the_whole_track(sizes):
    from roadbank.mapping.geo import CourseStream, course

    rng = np.random.default_rng(4)
    e = np.cumsum(rng.normal(0.2, 0.3, 1000))
    n = np.cumsum(rng.normal(0.1, 0.3, 1000))
    idx = np.arange(1000)
    stream, got, got_idx = CourseStream(), [], []
    for a, b in zip(np.cumsum([0] + sizes[:-1]), np.cumsum(sizes)):
        crs, (i,) = stream.push(e[a:b], n[a:b], idx[a:b])
        got.append(crs)
        got_idx.append(i)
    crs, (i,) = stream.finish()
    got, got_idx = np.concatenate(got + [crs]), np.concatenate(got_idx + [i])
    np.testing.assert_array_equal(got_idx, idx)                   # every sample once, in order
    np.testing.assert_array_equal(got, course(e, n))              # NaN where the whole track has NaN


def test_a_log_streamed_in_small_chunks_maps_as_in_one_chunk(tmp_path):
    """The course needs samples either side of each one: chunk ends must not lose samples or cells."""
    _drive_with_positions(tmp_path, "track-lane1", seed=2)
    maps = {}
    for rows in (200, 1_000_000):
        bmap, recs = map_logs([tmp_path / "drive.parquet"], "kinematic", channels=tmp_path / "m.toml",
                              origin=(48.0, 11.0), chunk_rows=rows)
        assert recs[0].status == "ok", recs[0].error
        maps[rows] = (bmap.table(), recs[0].mapped)
    (small, n_small), (whole, n_whole) = maps[200], maps[1_000_000]
    assert n_small == n_whole > 1000
    for key in ("ix", "iy", "sector", "count"):
        np.testing.assert_array_equal(small[key], whole[key])
    np.testing.assert_allclose(small["bank_mean_deg"], whole["bank_mean_deg"], rtol=0, atol=1e-12)


def _drive_with_positions(tmp_path, scenario: str, seed: int):
    """A simulated drive with positions on its road (origin 48, 11) as ``drive.parquet`` and the channel
    map ``m.toml`` in ``tmp_path``; returns the scenario's result and the positions (deg)."""
    from roadbank.mapping.simulated import run_positions
    from roadbank.sim import SCENARIOS, run_scenario

    res = run_scenario(scenario, seed=seed)
    lat, lon = run_positions(res, SCENARIOS[scenario].road, LocalProjection(48.0, 11.0))
    pq.write_table(pa.table(dict(res.table(), lat=lat, lon=lon)), tmp_path / "drive.parquet")
    (tmp_path / "m.toml").write_text(MAP_TOML)
    return res, lat, lon


def test_a_log_that_adds_nothing_to_the_map_is_named(tmp_path):
    """A log whose position never moves (a receiver that froze) is read but gives no cell: the map is made of the
    other log, and the command names the frozen one instead of counting it among the mapped ones in silence."""
    t = np.arange(600) * 0.01
    cols = {"t": t, "vx": np.full(600, 20.0), "ay": np.full(600, 0.5), "r": np.zeros(600), "delta_f": np.zeros(600)}
    proj = LocalProjection(48.0, 11.0)
    lat, lon = proj.to_latlon(np.zeros(600), 20.0 * t)
    pq.write_table(pa.table(dict(cols, lat=lat, lon=lon)), tmp_path / "gps.parquet")
    pq.write_table(pa.table(dict(cols, lat=np.full(600, lat[0]), lon=np.full(600, lon[0]))), tmp_path / "froze.parquet")
    (tmp_path / "m.toml").write_text(MAP_TOML)
    r = CliRunner().invoke(main, ["map", str(tmp_path), "--channels", str(tmp_path / "m.toml"), "-e", "kinematic",
                                  "-o", str(tmp_path / "out" / "map.parquet")])
    assert r.exit_code == 0, r.output
    assert "froze.parquet: read, but none of its estimates is in the map" in r.output
    assert "of 2 log(s), 1 of them adding none" in r.output and "gps.parquet: read" not in r.output


def test_fixes_that_jump_farther_than_a_car_drives_are_left_out(tmp_path):
    """A receiver's glitches (five single fixes 3 km off, one second of fixes 10 000 km off) put those samples'
    estimates into cells the car never drove through. They are left out and said once, naming the position
    channels, the count and the first; the map is the clean log's cells with fewer samples: those left out and the
    course's 25 samples either side of each run of them. Fed in chunks the same fixes are left out."""
    from roadbank.mapping.geo import PositionJumps

    res, lat, lon = _drive_with_positions(tmp_path, "track-lane1", seed=2)
    clean, _ = map_logs([tmp_path / "drive.parquet"], "kinematic", channels=tmp_path / "m.toml", origin=(48.0, 11.0))
    glat, glon = lat.copy(), lon.copy()
    singles = [300, 700, 701 + 5, 900, 1200]
    glat[singles] += 0.03                                       # 3.3 km north
    stretch = slice(1000, 1100)                                  # 1 s at 100 Hz
    glat[stretch], glon[stretch] = -40.0, 150.0
    pq.write_table(pa.table(dict(res.table(), lat=glat, lon=glon)), tmp_path / "drive.parquet")
    bmap, recs = map_logs([tmp_path / "drive.parquet"], "kinematic", channels=tmp_path / "m.toml",
                          origin=(48.0, 11.0))
    assert recs[0].status == "ok", recs[0].error
    said = [w for w in recs[0].warnings if "jump farther than a car can drive" in w]
    assert len(said) == 1 and "105 fix(es)" in said[0] and "channels 'latitude' (column 'lat')" in said[0], said
    assert f"t = {res.signals.t[300]:.3f} s" in said[0]
    got, want = bmap.table(), clean.table()
    cells = lambda tab: {(x, y, s): c for x, y, s, c in zip(tab["ix"], tab["iy"], tab["sector"], tab["count"])}  # noqa
    g, w = cells(got), cells(want)
    assert set(g) <= set(w) and all(0 <= w[k] - g[k] for k in g) and sum(w.values()) - sum(g.values()) <= 105 + 6 * 50
    t = res.signals.t
    whole = PositionJumps().add(t, glat, glon)[0]
    parts, jumps = [], PositionJumps()
    for a, b in ((0, 250), (250, 1001), (1001, 1050), (1050, len(t))):
        parts.append(jumps.add(t[a:b], glat[a:b], glon[a:b])[0])
    np.testing.assert_array_equal(np.isnan(np.concatenate(parts)), np.isnan(whole))
    assert np.isnan(whole).sum() == 105 and jumps.count == 105


def test_a_wrong_track_before_the_true_one_gives_way_after_the_relock_time():
    """A receiver whose first fixes are elsewhere (a stale position before the first real fix): the true track's
    fixes are left out for RELOCK_S, then kept; a receiver whose fixes scatter by 10 m (white) keeps every fix."""
    from roadbank.mapping.geo import RELOCK_S, PositionJumps

    t = np.arange(0.0, 10.0, 0.1)
    proj = LocalProjection(48.0, 11.0)
    lat, lon = proj.to_latlon(np.random.default_rng(0).normal(0.0, 5.0, t.size), 20.0 * t)
    lat[:5] += 1.0                                               # 111 km off for the first 0.5 s
    kept = np.isfinite(PositionJumps().add(t, lat, lon)[0])
    first_true = np.argmax(t >= 0.5)
    assert kept[:5].all() and not kept[first_true:first_true + int(RELOCK_S / 0.1)].any()
    assert kept[first_true + int(RELOCK_S / 0.1) + 1:].all()
    noisy = proj.to_latlon(np.random.default_rng(1).normal(0.0, 10.0, t.size), 20.0 * t)     # white, 10 m
    assert np.isfinite(PositionJumps().add(t, *noisy)[0]).all()


@pytest.mark.parametrize("args, said", [(["--cell", "1e9"], "'--cell'"), (["--cell", "0"], "'--cell'"),
                                        (["--sectors", "100000"], "'--sectors'")])
def test_grid_options_out_of_range_are_usage_errors(tmp_path, args, said):
    """A 1e9 m cell (its centre at latitude 4534 deg before), a 0 m one (refused after the mapping had begun) and
    100 000 heading sectors: usage errors naming the option before any log is read; the library refuses them too."""
    res = CliRunner().invoke(main, ["map", str(tmp_path), "-o", str(tmp_path / "m.parquet"), *args])
    assert res.exit_code == 2 and said in res.output and "mapping" not in res.output, res.output
    with pytest.raises(ValueError):
        BankMap(LocalProjection(48.0, 8.0), **({"cell_m": float(args[1])} if args[0] == "--cell"
                                               else {"sectors": int(args[1])}))


def test_a_png_that_is_not_png_is_refused_before_the_map(tmp_path):
    """--png mp.txt: a usage error before any log is read (before: the map table was written, then the figure
    failed with exit 1)."""
    res = CliRunner().invoke(main, ["map", str(tmp_path), "-o", str(tmp_path / "m.parquet"),
                                    "--png", str(tmp_path / "mp.txt")])
    assert res.exit_code == 2 and "must end in .png" in res.output, res.output
    assert not (tmp_path / "m.parquet").exists()
