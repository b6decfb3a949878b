"""ROS 1 bags, ROS 2 bags (sqlite3 or mcap storage) and plain MCAP files, without a ROS installation.

Messages are read and deserialised with ``rosbags`` (its ``AnyReader`` takes a
ROS 1 ``.bag``, a ROS 2 bag directory or a bare ``.mcap``; message definitions
come from the file, or from the ROS 2 Humble type store for bags that carry
none). A channel of the channel map names a ``topic`` and a dotted ``field``
path into its message::

    lateral_acceleration = { topic = "/imu/data", field = "linear_acceleration.y", unit = "m/s^2" }
    yaw_rate = { topic = "/imu/data", field = "angular_velocity.z", unit = "rad/s" }
    speed = { topic = "/odom", field = "twist.twist.linear.x", unit = "m/s" }
    latitude = { topic = "/fix", field = "latitude", unit = "deg" }

Each sample is stamped with the message's ``header.stamp`` (``ros_time =
"header"``, the default; messages without a header use the log time) or the
recorder's log time (``ros_time = "log"``). ``sensor_msgs/NavSatFix`` samples
whose ``status.status`` is negative (no fix) are dropped. Body axes: ROS
(REP-103) bodies are FLU, the same as ISO 8855 (``convention = "FLU"`` or
``"ISO"``); IMUs in FRD/NED convention use ``convention = "FRD"`` (or ``"NED"``).

Needs the optional extra ``ros`` (``pip install 'roadbank[ros]'``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import LogError
from .formats import ROS_FORMATS as ROS_FORMATS  # the formats read_ros takes
from .types import RawTable


def _stamp(msg) -> float | None:
    h = getattr(msg, "header", None)
    st = getattr(h, "stamp", None)
    if st is None:
        return None
    sec = getattr(st, "sec", None)
    if sec is None:                     # ROS 1 style names
        sec, nsec = getattr(st, "secs", 0), getattr(st, "nsecs", 0)
    else:
        nsec = st.nanosec
    assert sec is not None
    return float(sec) + 1e-9 * float(nsec)


def _field_names(msg) -> list[str]:
    return [k for k in getattr(type(msg), "__dataclass_fields__", {}) if not k.startswith("__")]


def _get_field(msg, path: str):
    """Value at a dotted ``path`` of a message; KeyError(part, available fields) if absent."""
    obj = msg
    for part in path.split("."):
        name, _, idx = part.partition("[")
        if not hasattr(obj, name):
            raise KeyError((part, _field_names(obj)))
        obj = getattr(obj, name)
        if idx:
            obj = obj[int(idx.rstrip("]"))]
    return obj


def read_ros(path, cmap, fmt: str) -> tuple[RawTable, list[str]]:
    """Read the channels of ``cmap`` (``topic`` + ``field`` each) from a bag or MCAP file.

    Parameters
    ----------
    path : path-like
        ROS 1 ``.bag``, ROS 2 bag directory (or its ``.db3`` / ``.mcap`` inside), or a plain ``.mcap``.
    cmap : ChannelMap
    fmt : str
        One of :data:`ROS_FORMATS`.

    Returns
    -------
    table : RawTable
        ``data`` / ``times`` (s) keyed by each channel's column (``topic:field``), stored units.
    warnings : list of str

    Raises
    ------
    LogError
        Naming the file, the channel, its topic and field: missing topic or field,
        a non-numeric field, a truncated or corrupt bag, a missing optional dependency.
    """
    p = Path(path)
    if not p.exists():
        raise LogError(f"{p}: file not found")
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise LogError(f"{p}: reading ROS bags / MCAP needs the optional dependency rosbags "
                       "(pip install 'roadbank[ros]')") from None
    if fmt == "rosbag2" and p.is_file() and (p.parent / "metadata.yaml").exists():
        p = p.parent                                   # the .db3/.mcap inside a bag directory
    if p.is_file() and p.stat().st_size == 0:
        raise LogError(f"{p}: file is empty")
    by_topic: dict[str, list] = {}
    for role, spec in cmap.channels.items():
        if role == "time":
            continue
        if not spec.topic:
            raise LogError(f"{cmap.source}: channel '{role}': a ROS channel needs 'topic' and 'field', "
                           "not 'column'")
        by_topic.setdefault(spec.topic, []).append((role, spec))
    vals: dict[str, list[float]] = {spec.column: [] for specs in by_topic.values() for _, spec in specs}
    stamps: dict[str, list[float]] = {spec.column: [] for specs in by_topic.values() for _, spec in specs}
    warns: list[str] = []
    dropped_nofix = 0
    unstamped: dict[str, int] = {}      # topic -> messages whose header stamp is zero
    try:
        with AnyReader([p], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            have = {c.topic: c.msgtype for c in reader.connections}
            for topic, specs in by_topic.items():
                if topic not in have:
                    role, spec = specs[0]
                    listing = ", ".join(f"{t} ({m})" for t, m in sorted(have.items())) or "none"
                    raise LogError(f"{p}: channel '{role}' (topic '{topic}', field '{spec.msg_field}'): "
                                   f"topic not in the file (it has: {listing})")
            conns = [c for c in reader.connections if c.topic in by_topic]
            for con, t_log, raw in reader.messages(connections=conns):
                msg = reader.deserialize(raw, con.msgtype)
                st = _stamp(msg) if cmap.ros_time == "header" else None
                t = st if st is not None and st > 0 else t_log * 1e-9
                if st is not None and not st > 0:       # a header never stamped: the recording time instead
                    unstamped[con.topic] = unstamped.get(con.topic, 0) + 1
                status = getattr(getattr(msg, "status", None), "status", None)
                if isinstance(status, int) and status < 0:      # NavSatFix without a fix
                    dropped_nofix += 1
                    continue
                for role, spec in by_topic[con.topic]:
                    try:
                        v = _get_field(msg, spec.msg_field)
                    except KeyError as exc:
                        part, names = exc.args[0]
                        raise LogError(f"{p}: channel '{role}' (topic '{con.topic}', field '{spec.msg_field}'): "
                                       f"no field '{part}' in {con.msgtype} (it has: {', '.join(names)})") from None
                    except (IndexError, ValueError):
                        raise LogError(f"{p}: channel '{role}' (topic '{con.topic}', field '{spec.msg_field}'): "
                                       "index out of range") from None
                    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.number)):
                        raise LogError(f"{p}: channel '{role}' (topic '{con.topic}', field '{spec.msg_field}'): "
                                       f"not a number in {con.msgtype} (a {type(v).__name__})")
                    vals[spec.column].append(float(v))
                    stamps[spec.column].append(t)
    except LogError:
        raise
    except Exception as exc:   # rosbags raises its own types for corrupt / truncated files
        raise LogError(f"{p}: not a readable {fmt} file (truncated or corrupt?): "
                       f"{type(exc).__name__}: {exc}") from None
    data, times = {}, {}
    for topic, specs in by_topic.items():
        for role, spec in specs:
            if not vals[spec.column]:
                raise LogError(f"{p}: channel '{role}' (topic '{topic}', field '{spec.msg_field}'): "
                               "no messages on the topic")
            ts = np.asarray(stamps[spec.column])
            v = np.asarray(vals[spec.column])
            order = np.argsort(ts, kind="stable")     # header stamps may arrive slightly out of order
            data[spec.column], times[spec.column] = v[order], ts[order]
    if dropped_nofix:
        warns.append(f"{p}: {dropped_nofix} message(s) with status < 0 (no GNSS fix) skipped")
    for topic, n in unstamped.items():
        warns.append(f"{p}: topic '{topic}': {n} message(s) with a zero header stamp, read at their recording time "
                     "instead (ros_time = \"log\" in the channel map reads every message so: one clock for all)")
    return RawTable(sorted(data), data, times=times, metadata={"format": fmt}, row_label="message"), warns
