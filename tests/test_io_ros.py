"""ROS 1 bags, ROS 2 bags (sqlite3 and mcap storage) and plain MCAP, written here from a simulated run.

Bags are written with rosbags' writers (and the plain MCAP with the independent
``mcap`` package); truth is the simulated signals that were written, so reading
back must return them on the estimator grid, in ISO 8855 / SI, whatever the bag's
body-axis convention (the ROS 1 bag carries an FRD/NED IMU, the others FLU).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("rosbags")
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin, Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from roadbank.io import LogError, detect_format, load_log  # noqa: E402

T0 = 1_700_000_000
LAT0, LON0 = 48.0, 11.0


def _latlon(s):
    """A fake straight northbound road: 1 m of path = 1/111 km of latitude."""
    return LAT0 + s / 111_000.0, np.full_like(s, LON0)


def _stamp(ts, t):
    sec = int(math.floor(t))
    return ts.types["builtin_interfaces/msg/Time"](sec=T0 + sec, nanosec=int(round((t - sec) * 1e9)))


def _header(ts, t, ros1, frame="base_link"):
    H = ts.types["std_msgs/msg/Header"]
    return H(seq=0, stamp=_stamp(ts, t), frame_id=frame) if ros1 else H(stamp=_stamp(ts, t), frame_id=frame)


def _messages(run, ts, ros1: bool, frd: bool):
    """(topic, type, t, msg) of the run: IMU 100 Hz, odometry 50 Hz, steering 100 Hz, GNSS 10 Hz."""
    T = ts.types
    V, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    s, swa = run.signals, run.steering_wheel_angle
    sign = -1.0 if frd else 1.0
    lat, lon = _latlon(run.truth.s - run.truth.s[0])
    out = []
    z9, z36 = np.zeros(9), np.zeros(36)
    for k, t in enumerate(s.t):
        out.append(("/imu/data", "sensor_msgs/msg/Imu", t, T["sensor_msgs/msg/Imu"](
            header=_header(ts, t, ros1), orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0), orientation_covariance=z9,
            angular_velocity=V(x=0.0, y=0.0, z=sign * s.r[k]), angular_velocity_covariance=z9,
            linear_acceleration=V(x=0.0, y=sign * s.ay[k], z=sign * 9.81), linear_acceleration_covariance=z9)))
        out.append(("/steering", "std_msgs/msg/Float64", t, T["std_msgs/msg/Float64"](data=math.degrees(swa[k]))))
        if k % 2 == 0:
            tw = T["geometry_msgs/msg/Twist"](linear=V(x=s.vx[k], y=0.0, z=0.0), angular=V(x=0.0, y=0.0, z=0.0))
            if ros1:
                P = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                                                orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0))
                out.append(("/odom", "nav_msgs/msg/Odometry", t, T["nav_msgs/msg/Odometry"](
                    header=_header(ts, t, ros1, "odom"), child_frame_id="base_link",
                    pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=P, covariance=z36),
                    twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=tw, covariance=z36))))
            else:
                out.append(("/twist", "geometry_msgs/msg/TwistStamped", t, T["geometry_msgs/msg/TwistStamped"](
                    header=_header(ts, t, ros1), twist=tw)))
        if k % 10 == 0:
            st = T["sensor_msgs/msg/NavSatStatus"](status=0, service=1)
            out.append(("/fix", "sensor_msgs/msg/NavSatFix", t, T["sensor_msgs/msg/NavSatFix"](
                header=_header(ts, t, ros1, "gps"), status=st, latitude=lat[k], longitude=lon[k], altitude=500.0,
                position_covariance=z9, position_covariance_type=0)))
    return out


def _write_ros1(path, msgs, ts):
    with Writer1(path) as w:
        conns = {}
        for topic, typ, t, m in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, typ, typestore=ts)
            w.write(conns[topic], int(round((T0 + t) * 1e9)), ts.serialize_ros1(m, typ))


def _write_ros2(path, msgs, ts, storage):
    with Writer2(path, version=8, storage_plugin=storage) as w:
        conns = {}
        for topic, typ, t, m in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, typ, typestore=ts)
            w.write(conns[topic], int(round((T0 + t) * 1e9)) + 2_000_000, ts.serialize_cdr(m, typ))


def _write_plain_mcap(path, msgs, ts):
    from mcap.writer import Writer
    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start(profile="ros2", library="roadbank tests")
        chans = {}
        for topic, typ, t, m in msgs:
            if topic not in chans:
                sid = w.register_schema(name=typ, encoding="ros2msg",
                                        data=ts.generate_msgdef(typ, ros_version=2)[0].encode())
                chans[topic] = w.register_channel(topic=topic, message_encoding="cdr", schema_id=sid)
            ns = int(round((T0 + t) * 1e9))
            w.add_message(channel_id=chans[topic], log_time=ns, publish_time=ns,
                          data=bytes(ts.serialize_cdr(m, typ)))
        w.finish()


MAP = """
convention = "{conv}"
steering_ratio = 16.0
[channels]
lateral_acceleration = {{ topic = "/imu/data", field = "linear_acceleration.y", unit = "m/s^2" }}
yaw_rate = {{ topic = "/imu/data", field = "angular_velocity.z", unit = "rad/s" }}
speed = {{ topic = "{speed_topic}", field = "{speed_field}", unit = "m/s" }}
steering_wheel_angle = {{ topic = "/steering", field = "data", unit = "deg", convention = "ISO" }}
latitude = {{ topic = "/fix", field = "latitude", unit = "deg" }}
longitude = {{ topic = "/fix", field = "longitude", unit = "deg" }}
"""


@pytest.fixture(scope="module")
def run():
    from roadbank.sim import run_scenario
    return run_scenario("bank-lane-change", seed=4)


@pytest.fixture(scope="module")
def bags(run, tmp_path_factory):
    d = tmp_path_factory.mktemp("bags")
    ts1, ts2 = get_typestore(Stores.ROS1_NOETIC), get_typestore(Stores.ROS2_HUMBLE)
    m1, m2 = _messages(run, ts1, True, frd=True), _messages(run, ts2, False, frd=False)
    out = {"rosbag1": d / "drive.bag", "rosbag2-sqlite3": d / "drive_sqlite", "rosbag2-mcap": d / "drive_mcap",
           "mcap": d / "plain.mcap"}
    _write_ros1(out["rosbag1"], m1, ts1)
    _write_ros2(out["rosbag2-sqlite3"], m2, ts2, StoragePlugin.SQLITE3)
    _write_ros2(out["rosbag2-mcap"], m2, ts2, StoragePlugin.MCAP)
    _write_plain_mcap(out["mcap"], m2, ts2)
    (d / "ros1.toml").write_text(MAP.format(conv="NED", speed_topic="/odom", speed_field="twist.twist.linear.x"))
    (d / "ros2.toml").write_text(MAP.format(conv="FLU", speed_topic="/twist", speed_field="twist.linear.x"))
    return d, out


@pytest.mark.parametrize("kind", ["rosbag1", "rosbag2-sqlite3", "rosbag2-mcap", "mcap"])
def test_bag_read_back(kind, bags, run):
    d, files = bags
    assert detect_format(files[kind]) == kind.split("-")[0]
    log = load_log(files[kind], channels=d / ("ros1.toml" if kind == "rosbag1" else "ros2.toml"))
    s, sim = log.signals, run.signals
    tt = s.t - T0
    # header stamps; std_msgs/Float64 (steering) has no header: its log time is used, 2 ms late in ROS 2
    lag = 0.002 if kind.startswith("rosbag2") else 0.0          # (plain MCAP written without the lag)
    assert abs(tt[0] - lag) < 1e-6 and np.allclose(np.diff(tt), 0.01, atol=1e-6)   # 100 Hz grid
    # written values back in ISO/SI (the ROS 1 IMU was FRD, read with convention = "NED")
    tol = 1e-5   # the values are exact; the grid of epoch times is good to ~1e-7 s (float64 at 1.7e9 s)
    np.testing.assert_allclose(s.r, np.interp(tt, sim.t, sim.r), atol=tol * 0.1)
    np.testing.assert_allclose(s.ay, np.interp(tt, sim.t, sim.ay), atol=tol)
    np.testing.assert_allclose(s.vx, np.interp(tt, sim.t[::2], sim.vx[::2]), atol=tol)
    np.testing.assert_allclose(s.delta_f * 16.0, np.interp(tt - lag, sim.t, run.steering_wheel_angle),
                               atol=tol)
    lat, lon = _latlon(run.truth.s - run.truth.s[0])
    np.testing.assert_allclose(log.extra["lat_deg"], np.interp(tt, sim.t[::10], lat[::10]), atol=1e-9)
    np.testing.assert_allclose(log.extra["lon_deg"], LON0)


def test_rosbag2_file_inside_directory_and_log_time(bags, tmp_path):
    d, files = bags
    db3 = next(files["rosbag2-sqlite3"].glob("*.db3"))
    assert detect_format(db3) == "rosbag2"
    text = (d / "ros2.toml").read_text().replace('convention = "FLU"', 'convention = "FLU"\nros_time = "log"')
    (tmp_path / "m.toml").write_text(text)
    log = load_log(db3, channels=tmp_path / "m.toml")
    assert abs(log.signals.t[0] - (T0 + 0.002)) < 1e-6     # the recorder's time, 2 ms after the stamp


def test_missing_topic_and_field(bags, tmp_path):
    d, files = bags
    (tmp_path / "t.toml").write_text((d / "ros2.toml").read_text().replace('"/twist"', '"/vehicle/twist"'))
    with pytest.raises(LogError, match=r"plain\.mcap: channel 'speed' \(topic '/vehicle/twist', field "
                                       r"'twist\.linear\.x'\): topic not in the file \(it has: .*/twist "
                                       r"\(geometry_msgs/msg/TwistStamped\)"):
        load_log(files["mcap"], channels=tmp_path / "t.toml")
    (tmp_path / "f.toml").write_text((d / "ros1.toml").read_text().replace("angular_velocity.z", "angular_rate.z"))
    with pytest.raises(LogError, match=r"drive\.bag: channel 'yaw_rate' \(topic '/imu/data', field "
                                       r"'angular_rate\.z'\): no field 'angular_rate' in sensor_msgs/msg/Imu "
                                       r"\(it has: header, orientation"):
        load_log(files["rosbag1"], channels=tmp_path / "f.toml")
    (tmp_path / "n.toml").write_text((d / "ros1.toml").read_text().replace('"/steering", field = "data"',
                                                                           '"/fix", field = "status"'))
    with pytest.raises(LogError, match=r"drive\.bag: channel 'steering_wheel_angle' \(topic '/fix', field "
                                       r"'status'\): not a number in sensor_msgs/msg/NavSatFix"):
        load_log(files["rosbag1"], channels=tmp_path / "n.toml")


def test_truncated_bag(bags, tmp_path):
    d, files = bags
    data = files["rosbag1"].read_bytes()
    bad = tmp_path / "cut.bag"
    bad.write_bytes(data[: len(data) // 2])
    with pytest.raises(LogError, match=r"cut\.bag: not a readable rosbag1 file \(truncated or corrupt"):
        load_log(bad, channels=d / "ros1.toml")
    mc = tmp_path / "cut.mcap"
    mc.write_bytes(files["mcap"].read_bytes()[:5000])
    with pytest.raises(LogError, match=r"cut\.mcap: not a readable mcap file"):
        load_log(mc, channels=d / "ros2.toml")


def test_robot_without_steering_topic(bags, tmp_path):
    """The steering topic is optional for ROS: delta_f is NaN, the modified-model estimators still run."""
    from roadbank import estimators
    d, files = bags
    text = "\n".join(ln for ln in (d / "ros2.toml").read_text().splitlines() if "steering_wheel_angle" not in ln)
    (tmp_path / "nosteer.toml").write_text(text)
    log = load_log(files["rosbag2-mcap"], channels=tmp_path / "nosteer.toml")
    assert np.all(np.isnan(log.signals.delta_f))
    est = estimators.make("kinematic").run(log.signals)
    assert est.valid[log.signals.vx >= 5.0].all()


@pytest.mark.parametrize("kind", ["rosbag1", "mcap"])
def test_stream_is_the_whole_log(kind, bags):
    """A bag streamed is one chunk equal to ``load_log`` (the same source and assembler), position too."""
    from roadbank.io.stream import stream_log
    d, files = bags
    cmap = d / ("ros1.toml" if kind == "rosbag1" else "ros2.toml")
    whole = load_log(files[kind], channels=cmap)
    chunks = list(stream_log(files[kind], channels=cmap, chunk_rows=50))
    assert len(chunks) == 1
    for k in ("t", "vx", "ay", "r", "delta_f"):
        np.testing.assert_array_equal(getattr(chunks[0].signals, k), getattr(whole.signals, k), err_msg=k)
    np.testing.assert_array_equal(chunks[0].extra["lat_deg"], whole.extra["lat_deg"])


def test_zero_header_stamps_are_read_at_recording_time_and_said(run, tmp_path):
    """An IMU driver that never stamps its headers (sec = nanosec = 0): its messages are read at their recording time,
    as before, and a warning names the topic and the count (it was silent)."""
    ts = get_typestore(Stores.ROS2_HUMBLE)
    msgs = _messages(run, ts, False, frd=False)
    zero = ts.types["builtin_interfaces/msg/Time"](sec=0, nanosec=0)
    for topic, _, _, m in msgs:
        if topic == "/imu/data":
            m.header.stamp = zero
    p = tmp_path / "unstamped.mcap"
    _write_plain_mcap(p, msgs, ts)
    (tmp_path / "m.toml").write_text(MAP.format(conv="FLU", speed_topic="/twist", speed_field="twist.linear.x"))
    log = load_log(p, channels=tmp_path / "m.toml")
    n = sum(1 for topic, *_ in msgs if topic == "/imu/data")
    said = [w for w in log.warnings if "topic '/imu/data'" in w]
    assert said and f"{n} message(s) with a zero header stamp, read at their recording time" in said[0], log.warnings
    assert abs(log.signals.t[0] - T0) < 1e-6 and np.allclose(np.diff(log.signals.t), 0.01, atol=1e-6)
