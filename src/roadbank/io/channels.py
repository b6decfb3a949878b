"""Channel maps: which column of a log is which signal, in which unit and sign convention.

A channel map is a small TOML file (read with the standard-library ``tomllib``)::

    convention = "ISO"        # sign/axis convention of the log: "ISO" (ISO 8855:
                              # x forward, y left, z up) or "FRD" (x forward,
                              # y right, z down); a channel may override it
    steering_ratio = 15.0     # optional; steering-wheel / road-wheel angle

    [resample]                # optional, see roadbank.io.resample
    time_base = "auto"        # "auto", "uniform", "clock" or a role name, e.g. "lateral_acceleration"
    rate_hz = 100.0           # rate of the uniform grid, 1 to 10000 Hz (RATE_HZ_RANGE)
    max_gap_s = 0.5           # longer gaps in a channel become NaN, never bridged

    [channels]
    time = { column = "timestamp", unit = "ms" }
    speed = { column = "v", unit = "km/h" }
    lateral_acceleration = { column = "acc_y", unit = "g" }
    yaw_rate = { column = "gyro_z", unit = "deg/s", convention = "FRD" }
    steering_wheel_angle = { column = "swa", unit = "deg", invert = true }
    reference_roll = { column = "roll", unit = "deg" }   # optional

Roles (the keys of ``[channels]``) and their accepted units:

==========================  ===================  ==================================
role                        units                FRD -> ISO sign
==========================  ===================  ==================================
time                        s, ms, us, ns        --
speed                       m/s, km/h, mph       none (x axis)
lateral_acceleration        m/s^2, g             flipped (y axis)
yaw_rate                    rad/s, deg/s         flipped (z axis)
steering_wheel_angle        rad, deg             flipped (rotation about z)
road_wheel_angle            rad, deg             flipped (rotation about z)
roll_rate                   rad/s, deg/s         none (rotation about x; optional:
                                                 the gyro-aided estimators read it)
longitudinal_acceleration   m/s^2, g             none (x axis; optional: the gyro-aided
                                                 estimators read the grade from it)
pitch_rate                  rad/s, deg/s         flipped (rotation about y; optional:
                                                 with the longitudinal acceleration,
                                                 the grade's pitch without lag)
reference_roll              rad, deg             none (rotation about x: right
                                                 side down in FRD = left side up
                                                 in ISO)
latitude, longitude         deg, rad             none (optional; for bank maps)
ecef_x, ecef_y, ecef_z      m, km                none (optional, instead of latitude /
                                                 longitude: WGS-84 ECEF position)
==========================  ===================  ==================================

Raw CAN (``dbc = "car.dbc"``, channels ``{ message = "...", signal = "...", unit = "..." }``)
and ROS (channels ``{ topic = "...", field = "...", unit = "..." }``, ``ros_time``) are
described in :mod:`roadbank.io.can`, :mod:`roadbank.io.ros` and docs/io.md; their channels
carry their own time stamps (no ``time`` role).
``convention`` also accepts ``FLU`` (= ISO) and ``NED`` (body axes FRD).

``time``, ``speed``, ``lateral_acceleration`` and ``yaw_rate`` are required. The steering
angle is ``road_wheel_angle`` or ``steering_wheel_angle`` (if both are given, the road-wheel
angle is used when its column exists in the file); a map with neither describes a log without
one (an IMU or INS log): it is read with the steering angle absent (``delta_f`` NaN), as a KITTI
drive is (:attr:`ChannelMap.no_steering`), which the default estimator does not read. ``invert = true``
flips a channel's sign on top of the convention, for sensors whose sign is odd. ``unbiased = true`` on
``roll_rate``, ``longitudinal_acceleration`` or ``pitch_rate`` says the channel is an INS's output whose offset its
own Kalman filter has removed (:attr:`ChannelMap.unbiased`, ``Signals.unbiased``); on any other channel it is an
error.
All conversion to SI and ISO 8855 happens here, at the edge; inside roadbank
everything is SI/ISO.

The default map (:func:`default_channel_map`) is roadbank's own column set, the
one ``roadbank simulate`` writes (SI, ISO): ``t, vx, ay, r, delta_f`` (or
``steering_wheel_angle`` divided by the steering ratio when ``delta_f`` is
absent) and the ``true_*`` truth columns, which are carried along as
:attr:`roadbank.io.Log.truth`.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import cast

import numpy as np

from ..constants import STEERING_RATIO_RANGE
from . import units
from .errors import LogError, channel_error, channel_text

#: role -> (unit kind, axis it lies along / rotates about; None for time)
ROLES: dict[str, tuple[str, str | None]] = {
    "time": ("time", None),
    "speed": ("speed", "x"),
    "lateral_acceleration": ("acceleration", "y"),
    "yaw_rate": ("angular_rate", "z"),
    "roll_rate": ("angular_rate", "x"),
    "longitudinal_acceleration": ("acceleration", "x"),
    "pitch_rate": ("angular_rate", "y"),
    "steering_wheel_angle": ("angle", "z"),
    "road_wheel_angle": ("angle", "z"),
    "reference_roll": ("angle", "x"),
    "latitude": ("angle", None),
    "longitude": ("angle", None),
    "ecef_x": ("length", None),
    "ecef_y": ("length", None),
    "ecef_z": ("length", None),
}
REQUIRED = ("time", "speed", "lateral_acceleration", "yaw_rate")
#: optional roles read when the file has their column -> the :class:`~roadbank.signals.Signals` channel they fill
OPTIONAL = {"roll_rate": "p", "longitudinal_acceleration": "ax", "pitch_rate": "q"}
STEERING = ("road_wheel_angle", "steering_wheel_angle")
CONVENTIONS = ("ISO", "FRD")
#: other spellings of the body-axis conventions: ROS REP-103 bodies are FLU (= ISO 8855);
#: NED systems (PX4, aerospace IMUs) give body rates and forces in FRD
CONVENTION_ALIASES = {"FLU": "ISO", "NED": "FRD"}
TIME_BASES = ("auto", "uniform", "clock")
#: accepted ``resample.rate_hz`` (Hz): below 1 Hz a grid cannot carry a car's lateral dynamics; above
#: 10 kHz (100x an ESP log's rate) it only costs memory (1e9 Hz would ask for 112 GiB on a 15 s log)
RATE_HZ_RANGE = (1.0, 10_000.0)


@dataclass(frozen=True)
class ChannelSpec:
    """Where one signal is in a log and how to convert it.

    Parameters
    ----------
    role : str
        One of :data:`ROLES`.
    column : str
        Column (CSV/Parquet) or channel (MDF4) name; for raw CAN
        ``"<message>.<signal>"`` (or the signal alone), for ROS ``"<topic>:<field>"``.
    unit : str
        Unit of the stored values (see :mod:`roadbank.io.units`).
    convention : str or None
        "ISO" or "FRD"; None means the map's default.
    invert : bool
        Extra sign flip on top of the convention.
    message, signal : str or None
        Raw CAN: DBC message (name or frame id, e.g. ``"0x130"``) and signal name.
    topic, msg_field : str or None
        ROS bags / MCAP: topic and dotted field path in its message
        (``"angular_velocity.z"``, ``"twist.twist.linear.x"``).
    """

    role: str
    column: str
    unit: str
    convention: str | None = None
    invert: bool = False
    message: str | None = None
    signal: str | None = None
    topic: str | None = None
    msg_field: str | None = None

    @property
    def kind(self) -> str:
        return ROLES[self.role][0]


@dataclass(frozen=True)
class ChannelMap:
    """Which column is which signal, with units and sign convention.

    Attributes
    ----------
    channels : dict role -> ChannelSpec
    convention : str
        Default convention of the channels, "ISO" or "FRD".
    steering_ratio : float or None
        Steering-wheel / road-wheel angle; None -> the vehicle parameters' ratio.
    time_base, rate_hz, max_gap_s
        Resampling settings, see :func:`roadbank.io.resample.common_time_base`; ``"clock"``: a
        table's own time column as it is, nothing interpolated (tables only).
    truth_prefix : str or None
        Columns starting with it are carried as truth (SI, ISO, no conversion).
    source : str
        Where the map came from (file name or "default"), for messages.
    dbc : str or None
        Raw CAN logs: the DBC file decoding them (absolute, or resolved against the
        map file's folder when read with :func:`read_channel_map`).
    ros_time : str
        ROS bags / MCAP: time stamp of a message, ``"header"`` (its ``header.stamp``,
        falling back to the log time for messages without a header) or ``"log"``
        (the time the recorder received it).
    no_steering : bool
        The log records no steering angle (a fixed layout such as KITTI's, or a map file that names
        no steering channel, :func:`channel_map_from_dict`): no steering channel is required and
        ``delta_f`` (rad) is NaN.
    steering_optional : bool
        A file that has none of the steering columns the map names is read with ``delta_f`` NaN and a
        warning, not refused (the default map: roadbank's default estimator does not read the
        steering angle, and an IMU or INS log has none); a map the user wrote names columns that
        must be there.
    fixed_layout : bool
        The map is a format's own documented layout (KITTI's OXTS files, comma2k19), not a user's: its optional
        channels are what the format says they are (``Signals.fixed``), with no map to get wrong.
    unbiased : frozenset of str
        The optional channels (``"p"``, ``"ax"``) that the format documents as free of offset (an INS's outputs,
        corrected by its own Kalman filter: KITTI's OXTS files): ``Signals.unbiased``.
    """

    channels: dict[str, ChannelSpec]
    convention: str = "ISO"
    steering_ratio: float | None = None
    time_base: str = "auto"
    rate_hz: float = 100.0
    max_gap_s: float = 0.5
    truth_prefix: str | None = None
    source: str = "<map>"
    dbc: str | None = None
    ros_time: str = "header"
    no_steering: bool = False
    steering_optional: bool = False
    fixed_layout: bool = False
    unbiased: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        src = self.source
        if self.convention not in CONVENTIONS:
            raise LogError(f"{src}: convention must be one of {CONVENTIONS}, got '{self.convention}'")
        if self.dbc is None and any(s.signal for s in self.channels.values()):
            raise LogError(f"{src}: channels name CAN signals but the map has no dbc = \"car.dbc\"")
        if self.ros_time not in ("header", "log"):
            raise LogError(f"{src}: ros_time must be 'header' or 'log', got '{self.ros_time}'")
        for role in REQUIRED:
            if role == "time":          # a table's reader asks for it; MDF4, CAN and ROS channels carry their own
                continue
            if role not in self.channels:
                raise LogError(f"{src}: channel map has no '{role}' channel (required)")
        ros = any(s.topic for s in self.channels.values())
        # robots often have no steering topic; some data sets record none
        if not any(r in self.channels for r in STEERING) and not ros and not self.no_steering:
            raise LogError(f"{src}: channel map needs 'road_wheel_angle' or 'steering_wheel_angle' "
                           "(or no_steering=True for a log without one)")
        for role, spec in self.channels.items():
            if role not in ROLES:
                raise LogError(f"{src}: unknown channel role '{role}' (known: {', '.join(ROLES)})")
            try:
                units.factor(ROLES[role][0], spec.unit)
            except ValueError as exc:
                raise channel_error(src, role, spec.column, str(exc)) from None
            if spec.convention is not None and spec.convention not in CONVENTIONS:
                raise channel_error(src, role, spec.column,
                                    f"convention must be one of {CONVENTIONS}, got '{spec.convention}'")
        if self.time_base not in TIME_BASES and self.time_base not in ROLES:
            raise LogError(f"{src}: resample.time_base must be 'auto', 'uniform', 'clock' or a role name, "
                           f"got '{self.time_base}'")
        lo, hi = RATE_HZ_RANGE
        if not lo <= self.rate_hz <= hi:
            raise LogError(f"{src}: resample.rate_hz = {self.rate_hz:g} is implausible: the grid's rate must be "
                           f"{lo:g} to {hi:g} Hz")
        if not self.max_gap_s > 0:
            raise LogError(f"{src}: resample.max_gap_s must be > 0, got {self.max_gap_s}")
        if self.steering_ratio is not None and not (self.steering_ratio > 0 and np.isfinite(self.steering_ratio)):
            raise LogError(f"{src}: steering_ratio must be a finite number > 0, got {self.steering_ratio}")

    def sign(self, role: str) -> float:
        """Sign factor taking a stored value of ``role`` to ISO 8855."""
        spec = self.channels[role]
        conv = spec.convention or self.convention
        axis = ROLES[role][1]
        s = -1.0 if (conv == "FRD" and axis in ("y", "z")) else 1.0
        return -s if spec.invert else s

    def to_si_iso(self, role: str, values: np.ndarray) -> np.ndarray:
        """Convert stored values of ``role`` to SI and ISO 8855 signs."""
        spec = self.channels[role]
        f = units.factor(spec.kind, spec.unit)
        s = self.sign(role) if role != "time" else 1.0
        return np.asarray(values, dtype=np.float64) * (f * s)


#: the :attr:`ChannelMap.source` of :func:`default_channel_map`: the map a log is read with when the user gave none
DEFAULT_MAP_SOURCE = "default channel map"
#: ... and of the map :func:`roadbank.io.mapchoice.choose_map` guesses for a log given without one
GUESSED_MAP_SOURCE = "channel map guessed from the log's columns"
#: the maps the user did not write: a channel they name is read where it can be, not demanded
UNWRITTEN_MAPS = (DEFAULT_MAP_SOURCE, GUESSED_MAP_SOURCE)


def steering_ratio_problem(ratio: float) -> str | None:
    """Why a steering ratio (steering-wheel angle per road-wheel angle, -) is no road vehicle's: outside
    :data:`roadbank.constants.STEERING_RATIO_RANGE` (a unit or typing mistake); None for one within it."""
    lo, hi = STEERING_RATIO_RANGE
    return None if lo <= ratio <= hi else (f"{ratio:g} is outside a road vehicle's {lo:g}-{hi:g} (steering-wheel "
                                           "angle per road-wheel angle, -)")


def default_channel_map() -> ChannelMap:
    """roadbank's own columns (as written by ``roadbank simulate``): SI, ISO 8855."""
    ch = {
        "time": ChannelSpec("time", "t", "s"),
        "speed": ChannelSpec("speed", "vx", "m/s"),
        "lateral_acceleration": ChannelSpec("lateral_acceleration", "ay", "m/s^2"),
        "yaw_rate": ChannelSpec("yaw_rate", "r", "rad/s"),
        "road_wheel_angle": ChannelSpec("road_wheel_angle", "delta_f", "rad"),
        "steering_wheel_angle": ChannelSpec("steering_wheel_angle", "steering_wheel_angle", "rad"),
        "roll_rate": ChannelSpec("roll_rate", "p", "rad/s"),
        "longitudinal_acceleration": ChannelSpec("longitudinal_acceleration", "ax", "m/s^2"),
        "pitch_rate": ChannelSpec("pitch_rate", "q", "rad/s"),
    }
    return ChannelMap(ch, truth_prefix="true_", source=DEFAULT_MAP_SOURCE, steering_optional=True)


_TOP_KEYS = {"convention", "steering_ratio", "resample", "channels", "truth_prefix", "dbc", "ros_time"}
_RESAMPLE_KEYS = {"time_base", "rate_hz", "max_gap_s"}
_CHANNEL_KEYS = {"column", "unit", "convention", "invert", "message", "signal", "topic", "field", "unbiased"}


def _convention(value) -> str | None:
    if value is None:
        return None
    c = str(value).upper()
    return CONVENTION_ALIASES.get(c, c)


def _column_of(source, role: str, entry: dict) -> str:
    """The key a channel is stored under: ``column``, ``message.signal`` (CAN) or ``topic:field`` (ROS)."""
    if "signal" in entry or "message" in entry:
        if "signal" not in entry:
            raise LogError(f"{source}: channel '{role}': 'message' without 'signal'")
        msg = entry.get("message")
        return f"{msg}.{entry['signal']}" if msg is not None else str(entry["signal"])
    if "topic" in entry or "field" in entry:
        if "topic" not in entry or "field" not in entry:
            raise LogError(f"{source}: channel '{role}': a ROS channel needs both 'topic' and 'field'")
        return f"{entry['topic']}:{entry['field']}"
    if "column" not in entry:
        raise LogError(f"{source}: channel '{role}': no 'column' (or 'signal' for CAN, "
                       "'topic' + 'field' for ROS)")
    return str(entry["column"])


def _number(source, key: str, value) -> float:
    """``value`` of map key ``key`` as a float; LogError naming the map and the key for anything but a
    number (a TOML string such as "sixteen", a boolean, a table)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise LogError(f"{source}: {key} must be a number, got {value!r}")
    try:
        return float(value)
    except ValueError:
        raise LogError(f"{source}: {key} must be a number, got {value!r}") from None


def channel_map_from_dict(d: dict, source: str = "<map>") -> ChannelMap:
    """Build a :class:`ChannelMap` from the parsed TOML structure (see module doc).

    A map that names neither ``road_wheel_angle`` nor ``steering_wheel_angle`` describes a log without a
    steering angle (:attr:`ChannelMap.no_steering`: ``delta_f`` NaN, rad)."""
    if not isinstance(d, dict):
        raise LogError(f"{source}: a channel map must be a table")
    unknown = set(d) - _TOP_KEYS
    if unknown:
        raise LogError(f"{source}: unknown key(s) {sorted(unknown)} (known: {sorted(_TOP_KEYS)})")
    chans = d.get("channels")
    if not isinstance(chans, dict) or not chans:
        raise LogError(f"{source}: missing [channels] table")
    specs, unbiased = {}, set()
    for role, entry in chans.items():
        if role not in ROLES:
            raise LogError(f"{source}: unknown channel role '{role}' (known: {', '.join(ROLES)})")
        if isinstance(entry, str):
            entry = {"column": entry}
        if not isinstance(entry, dict):
            raise LogError(f"{source}: channel '{role}' must be a table like "
                           "{ column = \"...\", unit = \"...\" }")
        bad = set(entry) - _CHANNEL_KEYS
        if bad:
            raise LogError(f"{source}: channel '{role}': unknown key(s) {sorted(bad)} "
                           f"(known: {sorted(_CHANNEL_KEYS)})")
        column = _column_of(source, role, entry)
        if "unit" not in entry:
            raise channel_error(source, role, column,
                                f"no 'unit' (SI would be '{units.SI_UNIT[ROLES[role][0]]}'; "
                                "state it explicitly)")
        if entry.get("unbiased", False) is not False:
            if role not in OPTIONAL or entry["unbiased"] is not True:
                raise channel_error(source, role, column, "'unbiased = true' is for the roll rate, the "
                                    "longitudinal acceleration and the pitch rate of an INS whose outputs are free "
                                    "of offset")
            unbiased.add(OPTIONAL[role])
        invert = entry.get("invert", False)
        if not isinstance(invert, bool):         # "false" (a string) would read as true
            raise channel_error(source, role, column, f"'invert' must be true or false (a TOML boolean, no quotes), "
                                f"got {invert!r}")
        opt = {k: (None if entry.get(k) is None else str(entry[k])) for k in ("message", "signal", "topic")}
        specs[role] = ChannelSpec(role, column, str(entry["unit"]), _convention(entry.get("convention")),
                                  invert, msg_field=(
                                      None if entry.get("field") is None else str(entry["field"])), **opt)
    rs = d.get("resample", {})
    if not isinstance(rs, dict):
        raise LogError(f"{source}: [resample] must be a table")
    bad = set(rs) - _RESAMPLE_KEYS
    if bad:
        raise LogError(f"{source}: [resample]: unknown key(s) {sorted(bad)} (known: {sorted(_RESAMPLE_KEYS)})")
    ratio = None if d.get("steering_ratio") is None else _number(source, "steering_ratio", d["steering_ratio"])
    why = steering_ratio_problem(ratio) if ratio is not None and np.isfinite(ratio) and ratio > 0 else None
    if why is not None:                                 # (not finite or not positive: ChannelMap's own message)
        raise LogError(f"{source}: steering_ratio = {why}")
    try:
        return ChannelMap(
            specs,
            convention=cast(str, _convention(d.get("convention", "ISO"))),   # a default is given: never None
            steering_ratio=ratio,
            time_base=str(rs.get("time_base", "auto")),
            rate_hz=_number(source, "resample.rate_hz", rs.get("rate_hz", 100.0)),
            max_gap_s=_number(source, "resample.max_gap_s", rs.get("max_gap_s", 0.5)),
            truth_prefix=d.get("truth_prefix"),
            source=source,
            dbc=None if d.get("dbc") is None else str(d["dbc"]),
            ros_time=str(d.get("ros_time", "header")),
            no_steering=not any(r in specs for r in STEERING),
            unbiased=frozenset(unbiased),
        )
    except (TypeError, ValueError) as exc:
        if isinstance(exc, LogError):
            raise
        raise LogError(f"{source}: {exc}") from None


def read_channel_map(path) -> ChannelMap:
    """Read a channel map from a TOML file.

    Raises
    ------
    LogError
        If the file is missing, not valid TOML, or the map is incomplete / uses
        an unknown role, unit or convention.
    """
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            d = tomllib.load(fh)
    except FileNotFoundError:
        raise LogError(f"{p}: channel map not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise LogError(f"{p}: not a valid TOML channel map ({exc})") from None
    except UnicodeDecodeError as exc:      # TOML is UTF-8 text (a Latin-1 "°" in a comment, a binary file)
        raise LogError(f"{p}: not a valid TOML channel map (not UTF-8 text: byte 0x{exc.object[exc.start]:02x} "
                       f"at position {exc.start})") from None
    except OSError as exc:
        raise LogError(f"{p}: cannot read the channel map ({exc.strerror})") from None
    if isinstance(d, dict) and isinstance(d.get("dbc"), str):
        d = dict(d, dbc=str(p.parent / d["dbc"]))   # relative to the map file (absolute stays)
    return channel_map_from_dict(d, source=str(p))


# ---------------------------------------------------------------- plausibility
def _time_unit_hint(dt_si: float, declared_unit: str) -> str:
    """`` (is the unit ns? ...)``: the time unit under which a time column's median step, ``dt_si`` s with
    the ``declared_unit``, is a plausible sample period (10 us to 1 s; the one nearest 10 ms when several
    are), or '' when none is."""
    stored = dt_si / units.factor("time", declared_unit)
    fits = {u: stored * f for u, f in units.FACTORS["time"].items() if 1e-5 <= stored * f <= 1.0}
    if not fits:
        return ""
    unit = min(fits, key=lambda u: abs(np.log10(fits[u] / 0.01)))
    return f" (is the unit {unit}? that gives a period of {fits[unit]:g} s)"


def check_period(source, role: str, column: str, declared_unit: str, t_si: np.ndarray, what: str = "") -> None:
    """LogError naming the channel where the median step of its time stamps ``t_si`` (s, read with the
    ``declared_unit``) is no ESP log's sample period (above 1 s, or below 10 us), with the unit that would make it one;
    ``what`` opens the message (whose stamps: a channel on its own clock)."""
    v = t_si[np.isfinite(t_si)]
    if len(v) <= 2:
        return
    dt = float(np.median(np.diff(v)))
    if dt > 1.0:
        raise channel_error(source, role, column, f"{what}median sample period {dt:g} s with unit '{declared_unit}': "
                            f"implausible for an ESP log{_time_unit_hint(dt, declared_unit)}")
    if 0 < dt < 1e-5:
        raise channel_error(source, role, column, f"{what}median sample period {dt:g} s with unit '{declared_unit}' "
                            f"(> 100 kHz): implausible{_time_unit_hint(dt, declared_unit)}")


def check_plausible(source, role: str, column: str, declared_unit: str,
                    t_si: np.ndarray | None, v_si: np.ndarray) -> list[str]:
    """Catch units that are obviously wrong, after conversion to SI.

    Raises :class:`LogError` for values impossible for a road car in the
    declared unit (naming the channel and the likely unit); returns warning
    strings for values that are merely suspicious.
    """
    warn: list[str] = []
    v = v_si[np.isfinite(v_si)]
    if role == "time":
        check_period(source, role, column, declared_unit, v)
        return warn
    if len(v) == 0:
        return warn
    a = np.abs(v)
    med, p99 = (float(x) for x in np.percentile(a, [50, 99]))    # one partition for both
    if role == "speed" and med > 70.0:
        hint = " -- probably km/h" if units.normalise_unit(declared_unit) == "m/s" else ""
        raise channel_error(source, role, column,
                            f"median speed {med:.1f} m/s after converting from '{declared_unit}' "
                            f"exceeds 70 m/s{hint}")
    if role == "lateral_acceleration" and p99 > 25.0:
        hint = " -- probably m/s^2, not g" if units.normalise_unit(declared_unit) == "g" else ""
        raise channel_error(source, role, column,
                            f"99th-percentile |ay| = {p99:.1f} m/s^2 after converting from "
                            f"'{declared_unit}' exceeds 2.5 g{hint}")
    if role == "yaw_rate" and p99 > 2.0:
        hint = " -- probably deg/s" if units.normalise_unit(declared_unit) == "rad/s" else ""
        raise channel_error(source, role, column,
                            f"99th-percentile |yaw rate| = {p99:.2f} rad/s after converting from "
                            f"'{declared_unit}' exceeds 2 rad/s (115 deg/s){hint}")
    if role == "steering_wheel_angle":
        mx = float(a.max())
        if mx > 4 * np.pi:
            raise channel_error(source, role, column,
                                f"|steering-wheel angle| reaches {mx:.1f} rad (> 720 deg) after "
                                f"converting from '{declared_unit}' -- probably deg")
        if p99 > 2 * np.pi:
            warn.append(channel_text(source, role, column, f"99th-percentile |angle| {np.degrees(p99):.0f} deg "
                                     "exceeds one turn; check the unit"))
    if role == "road_wheel_angle" and p99 > 1.0:
        raise channel_error(source, role, column,
                            f"99th-percentile |road-wheel angle| = {p99:.2f} rad after converting "
                            f"from '{declared_unit}' exceeds 1 rad -- probably deg, or a "
                            "steering-wheel angle mapped as road-wheel angle")
    if role == "reference_roll" and p99 > 0.6:
        raise channel_error(source, role, column,
                            f"99th-percentile |roll| = {p99:.2f} rad after converting from "
                            f"'{declared_unit}' exceeds 0.6 rad (34 deg) -- probably deg")
    return warn
