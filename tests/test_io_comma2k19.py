"""comma2k19 layout: pose-derived roll geometry (independent constructions) and the real segment."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from roadbank.io import LogError, load_log
from roadbank.io.comma2k19 import ellipsoid_down_ecef, load_comma2k19, pose_roll

SEGMENT = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "comma2k19-example"
needs_data = pytest.mark.skipif(not SEGMENT.is_dir(), reason=f"comma2k19 example segment absent at {SEGMENT}")


def test_ellipsoid_normal_from_geodetic_position():
    # position on the WGS-84 ellipsoid at geodetic latitude 37.4 deg, longitude -122.2 deg
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)
    lat, lon = math.radians(37.4), math.radians(-122.2)
    N = a / math.sqrt(1 - e2 * math.sin(lat) ** 2)
    h = 30.0
    pos = np.array([[(N + h) * math.cos(lat) * math.cos(lon), (N + h) * math.cos(lat) * math.sin(lon),
                     (N * (1 - e2) + h) * math.sin(lat)]])
    up = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
    np.testing.assert_allclose(ellipsoid_down_ecef(pos)[0], -up, atol=1e-9)


@pytest.mark.parametrize("phi_deg", [-3.0, 0.0, 1.25, 10.0])
def test_pose_roll_sign_and_value(phi_deg):
    # Camera at the equator, longitude 0: down = -X. Facing north (+Z): right = east (+Y).
    # Rolling right side down by phi (ISO positive) must give roll = +phi.
    phi = math.radians(phi_deg)
    f = np.array([0.0, 0.0, 1.0])
    r = np.array([0.0, 1.0, 0.0])
    d = np.array([-1.0, 0.0, 0.0])
    r2 = r * math.cos(phi) + d * math.sin(phi)
    d2 = d * math.cos(phi) - r * math.sin(phi)
    R = np.column_stack([f, r2, d2])          # camera axes in ECEF: maps camera -> ECEF
    x, y, z, w = Rotation.from_matrix(R).as_quat()   # scipy: scalar last
    q = np.array([[w, x, y, z]])
    pos = np.array([[6378137.0, 0.0, 0.0]])
    assert pose_roll(pos, q)[0] == pytest.approx(phi, abs=1e-12)


@needs_data
def test_real_segment_loads_with_iso_signs():
    log = load_log(SEGMENT)
    s = log.signals
    assert log.format == "comma2k19"
    np.testing.assert_allclose(np.diff(s.t), 0.01, atol=1e-9)
    acc = np.load(SEGMENT / "processed_log/IMU/accelerometer/value", allow_pickle=False)
    acc_t = np.load(SEGMENT / "processed_log/IMU/accelerometer/t", allow_pickle=False)
    gyr = np.load(SEGMENT / "processed_log/IMU/gyro/value", allow_pickle=False)
    # the grid's values are the negated raw samples interpolated linearly (numpy's interp, independent of the reader)
    np.testing.assert_allclose(s.ay, np.interp(s.t, acc_t, -acc[:, 1]), rtol=0, atol=1e-12)
    # means are the negated raw means (interpolation preserves them closely)
    assert np.mean(s.ay) == pytest.approx(-np.mean(acc[:, 1]), abs=0.02)
    assert np.mean(s.r) == pytest.approx(-np.mean(gyr[:, 2]), abs=0.002)
    # the pose's last frame comes 0.075 s before the inputs' last samples: no reference roll after it (NaN), the
    # log keeping the inputs' span
    last_frame = np.load(SEGMENT / "global_pose/frame_times", allow_pickle=False)[-1]
    np.testing.assert_array_equal(np.isnan(log.reference_roll), s.t > last_frame)
    assert np.count_nonzero(s.t > last_frame) == 8
    # README: reference roll about 0.4 to 1.8 deg, mean about 1.25 deg
    ref = np.degrees(log.reference_roll[s.t <= last_frame])
    assert 0.3 < ref.min() < 0.5 and 1.7 < ref.max() < 1.9
    assert np.mean(ref) == pytest.approx(1.25, abs=0.1)
    # speed 8-20 m/s, steering: left turn -> positive delta (correlates with ISO yaw rate)
    assert 7.5 < s.vx.min() and s.vx.max() < 20.5
    assert np.corrcoef(s.delta_f, s.r)[0, 1] > 0.5


def test_missing_and_truncated_segment_files(tmp_path):
    seg = tmp_path / "seg"
    (seg / "processed_log" / "IMU" / "accelerometer").mkdir(parents=True)
    with pytest.raises(LogError, match="processed_log/IMU/accelerometer/t' is missing"):
        load_log(seg)
    np.save(seg / "processed_log/IMU/accelerometer/t.npy", np.arange(10.0))
    (seg / "processed_log/IMU/accelerometer/t.npy").rename(seg / "processed_log/IMU/accelerometer/t")
    b = (seg / "processed_log/IMU/accelerometer/t").read_bytes()
    (seg / "processed_log/IMU/accelerometer/t").write_bytes(b[:-20])
    with pytest.raises(LogError, match="unreadable"):
        load_log(seg)


@needs_data
def test_real_segment_is_the_documented_mapping_on_the_common_grid():
    """The segment read through the assembler equals the mapping of the module docstring computed here
    from the raw arrays with the resampling rules alone (:mod:`roadbank.io.resample`): ``ay = -accel[:, 1]``,
    ``r = -gyro[:, 2]``, the CAN speed, the steering-wheel angle in rad over the steering ratio, the pose
    roll and position, all on the uniform 100 Hz grid over the inputs' overlap (the pose roll, no input, does not
    bound it: NaN after its last frame), bit for bit."""
    from roadbank.io.comma2k19 import ecef_to_latlon
    from roadbank.io.resample import common_time_base, interpolate, resample
    from roadbank.params import VehicleParams

    def arr(rel):
        return np.load(SEGMENT / rel, allow_pickle=False)

    acc, gyr = arr("processed_log/IMU/accelerometer/value"), arr("processed_log/IMU/gyro/value")
    pos, quat = arr("global_pose/frame_positions"), arr("global_pose/frame_orientations")
    ft = arr("global_pose/frame_times")
    series = {"speed": (arr("processed_log/CAN/speed/t"), arr("processed_log/CAN/speed/value").reshape(-1)),
              "ay": (arr("processed_log/IMU/accelerometer/t"), -acc[:, 1]),
              "r": (arr("processed_log/IMU/gyro/t"), -gyr[:, 2]),
              "swa": (arr("processed_log/CAN/steering_angle/t"),
                      np.radians(arr("processed_log/CAN/steering_angle/value").reshape(-1))),
              "roll": (ft, pose_roll(pos, quat))}
    for ratio, rate, gap in ((None, 100.0, 0.5), (12.0, 50.0, 0.2)):
        params = VehicleParams() if ratio is None else VehicleParams().replace(steering_ratio=ratio)
        log = load_comma2k19(SEGMENT, params=params, rate_hz=rate, max_gap_s=gap)
        t = common_time_base({k: v for k, v in series.items() if k != "roll"}, "uniform", rate)
        want = resample(series, t, gap)
        s = log.signals
        np.testing.assert_array_equal(s.t, t)
        for got, key in ((s.vx, "speed"), (s.ay, "ay"), (s.r, "r"), (log.reference_roll, "roll")):
            np.testing.assert_array_equal(got, want[key], err_msg=key)
        np.testing.assert_array_equal(s.delta_f, want["swa"] / params.steering_ratio)
        lat, lon = ecef_to_latlon(pos)
        np.testing.assert_array_equal(log.extra["lat_deg"], interpolate(ft, np.degrees(lat), t, gap))
        np.testing.assert_array_equal(log.extra["lon_deg"], interpolate(ft, np.degrees(lon), t, gap))
        assert log.metadata["steering_ratio"] == str(params.steering_ratio) and log.warnings == []


@needs_data
def test_damaged_stamps_are_repaired_as_in_any_log(tmp_path):
    """Two gyro samples with their stamps swapped: the time-stamp repair of every format puts them back
    in order, flags them not valid and says so, naming the file and the channel. The gyro gives three channels
    on its one clock (yaw, roll and pitch rate), each repaired and named."""
    import shutil
    seg = tmp_path / "seg"
    shutil.copytree(SEGMENT, seg)
    f = seg / "processed_log/IMU/gyro/t"
    t = np.load(f, allow_pickle=False)
    t[2000], t[2001] = t[2001], t[2000]
    with open(f, "wb") as fh:
        np.save(fh, t)
    log = load_log(seg)
    assert log.time_repairs["swapped"] == 3 and log.time_repairs["flagged"] == 6
    for role, axis in (("yaw_rate", 2), ("roll_rate", 0), ("pitch_rate", 1)):
        assert any(f"channel '{role}' (column 'processed_log/IMU/gyro[{axis}]'): time stamps repaired: 1 swapped "
                   "pair" in w for w in log.warnings)
    assert len(log) == len(load_log(SEGMENT))


def test_a_file_that_is_not_one_real_array_is_refused_naming_it(tmp_path):
    """An .npz archive saved under a segment's .npy name (np.load returns an archive, not an array) and complex
    values are refused naming the segment and the file, not read into a conversion error without a file."""
    from roadbank.io.comma2k19 import _load

    (tmp_path / "processed_log" / "CAN" / "speed").mkdir(parents=True)
    f = tmp_path / "processed_log" / "CAN" / "speed" / "value"
    with open(f, "wb") as fh:
        np.savez(fh, a=np.arange(3.0))
    with pytest.raises(LogError, match="'processed_log/CAN/speed/value' is not one array .* NpzFile"):
        _load(tmp_path, "processed_log/CAN/speed/value")
    with open(f, "wb") as fh:
        np.save(fh, np.arange(3.0) + 1j)
    with pytest.raises(LogError, match="'processed_log/CAN/speed/value' holds complex128 values, not real numbers"):
        _load(tmp_path, "processed_log/CAN/speed/value")
    with open(f, "wb") as fh:
        np.save(fh, np.arange(3, dtype=np.int8))
    assert _load(tmp_path, "processed_log/CAN/speed/value").tolist() == [0, 1, 2]


@needs_data
def test_a_segment_without_its_pose_or_steering_is_read_without_them(tmp_path):
    """The pose is the reference, not a channel the estimate reads; the steering angle is read only by the
    original-model filters. A segment without ``global_pose/`` (before: refused whole) is read with the same signals,
    no reference roll and no positions, and a warning naming the folder and what is lost; one without the steering
    angle reads it as NaN, saying so; the estimate of the default on both is the full segment's to the bit where the
    steering is not read, and within its samples where the online offsets read it."""
    import shutil

    from roadbank import estimators

    full = load_log(SEGMENT)
    no_pose, no_steer = tmp_path / "no_pose", tmp_path / "no_steer"
    shutil.copytree(SEGMENT, no_pose)
    shutil.rmtree(no_pose / "global_pose")
    shutil.copytree(SEGMENT, no_steer)
    shutil.rmtree(no_steer / "processed_log/CAN/steering_angle")

    log = load_log(no_pose)
    assert log.reference_roll is None and "lat_deg" not in log.extra
    assert any("'global_pose' is missing" in w and "no reference roll" in w for w in log.warnings), log.warnings
    # the pose no longer bounds the log's span (the reference is no input): the same samples with or without it
    assert np.array_equal(log.signals.t, full.signals.t)
    inner = (log.signals.t >= full.signals.t[0]) & (log.signals.t <= full.signals.t[-1])
    assert np.array_equal(log.signals.t[inner], full.signals.t)
    assert np.array_equal(log.signals.ay[inner], full.signals.ay)

    log = load_log(no_steer)
    assert np.isnan(log.signals.delta_f).all() and log.reference_roll is not None
    assert any("steering_angle' is missing" in w and "steering angle is NaN" in w for w in log.warnings)
    est = estimators.make("kinematic-gyro")
    assert np.isfinite(est.run(log.signals).theta).mean() > 0.9


@needs_data
def test_a_pose_without_a_fix_is_not_read_as_a_roll_in_degrees(tmp_path):
    """Positions all at the Earth's centre (a receiver without a fix writes zeros): before, the roll of such a pose
    was refused as a reference roll "probably in deg"; now the frames off the Earth have no roll, and with none left
    the segment is read without its pose, saying why. The second half of the frames without a fix: the log is the
    full segment (the reference, no input, does not cut it; before, the log was the first half), its reference the
    full pose's roll up to the last frame with a fix and NaN after it, which a warning says."""
    import shutil

    seg = tmp_path / "seg"
    shutil.copytree(SEGMENT, seg)
    f = seg / "global_pose" / "frame_positions"
    pos = np.load(f, allow_pickle=False)
    with open(f, "wb") as fh:
        np.save(fh, np.zeros_like(pos))
    log = load_log(seg)
    assert log.reference_roll is None
    assert any("no frame of the" in w and "on the Earth" in w and "without a fix" in w for w in log.warnings)

    half = pos.copy()
    half[len(pos) // 2:] = 0.0
    with open(f, "wb") as fh:
        np.save(fh, half)
    log, full = load_log(seg), load_log(SEGMENT)
    assert any(f"{len(pos) - len(pos) // 2} of the {len(pos)} frames are not on the Earth" in w for w in log.warnings)
    assert np.array_equal(log.signals.t, full.signals.t) and np.array_equal(log.signals.ay, full.signals.ay)
    last_fix = np.load(SEGMENT / "global_pose/frame_times", allow_pickle=False)[len(pos) // 2 - 1]
    covered = log.signals.t <= last_fix
    assert 0.45 < covered.mean() < 0.55
    assert np.array_equal(log.reference_roll[covered], full.reference_roll[covered])
    assert np.isnan(log.reference_roll[~covered]).all()
    assert any("channel 'reference_roll'" in w and f"covers 46408.590 to {log.signals.t[covered][-1]:.3f} s of the "
               "log's 46408.590 to 46468.570 s" in w for w in log.warnings), log.warnings
