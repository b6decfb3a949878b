"""Guess a channel map for a foreign log: which column is which signal, its unit and its sign.

Evidence, per channel:

* **names** -- common spellings (``VehSpd``, ``speed``, ``v``; ``YawRate``, ``wz``, ``gyro_z``;
  ``LatAcc``, ``ay``; ``SteerAngle``, ``SWA``; ``timestamp``, ``time`` ...) and unit hints in
  them (``_kmh``, ``_mph``, ``_degps``, ``_ms``), also after a CAN message's name (``ESP_21.LatAcc``);
* **ranges** -- a sample period of 1-100 ms in s, ms, us or ns; speeds above 70 are not m/s;
  |ay| above 1.5 is not g; |yaw rate| above 2 is not rad/s; steering angles above 2 pi are deg;
* **physics** -- in turns ``ay = vx r`` (steady cornering), which fixes the speed, ay and yaw-rate
  units together and the yaw rate's sign relative to ``ay``; and the steering angle against the
  kinematic road-wheel angle ``L r / vx`` (L = 2.7 m), which tells a road-wheel from a
  steering-wheel angle, its unit and its sign.

The units are chosen among every combination the ranges allow (speed: m/s, km/h and mph) by the slope
of ``ay`` on ``vx r`` over the stronger turns: real roads give 0.7-1.3 (:data:`SLOPE_BAND`: a banked
curve lowers it, the body's roll raises it), and the combination nearest the band's middle wins, or
the one a unit in a column's name states. km/h and mph differ by a factor 1.61 only, less than the
band spans: a unit is ``high`` only when no other unit of its channel gives a slope inside the band,
and the guess names the other unit when one does.

Each guess says how sure it is: ``high`` (name and data agree), ``medium`` (one of them, the
other silent) or ``low`` (data only, a conflict, or two units the data cannot tell apart). The
signs are read relative to ``ay``: ``ay`` is taken as ISO 8855 (positive to the left), an
assumption the map states (:data:`CONVENTION_NOTE`): a log whose ay, yaw rate and steering are all
positive to the right balances ``ay = vx r`` exactly as well, and no single log can tell a mirrored
car from a mirrored sensor. A log with no column named like a steering angle gets a map without a
steering channel (:data:`NO_STEERING`).
"""

from __future__ import annotations

import functools
import itertools
import math
import re
import textwrap
import unicodedata
from dataclasses import dataclass

import numpy as np

from .channels import OPTIONAL, ROLES, STEERING
from .units import FACTORS, normalise_unit

#: role -> name spellings (normalised: lower case, letters and digits only)
NAMES = {
    "time": ("t", "time", "timestamp", "times", "ts", "timest", "zeit", "timesec", "stamp", "logtime"),
    "speed": ("vx", "v", "speed", "vehspd", "vehiclespeed", "velocity", "vel", "spd", "vspeed", "vehspeed",
              "speedx", "velx", "vlgt", "groundspeed", "vehiclevelocity",
              # a VW-style CAN signal (``ESP_v_Signal`` of the ESP's message, km/h): v as a symbol, then "Signal"
              "vsignal",
              # German (an umlaut reads as its vowel, or written ae, oe, ue), French (accents dropped)
              "geschwindigkeit", "fahrzeuggeschwindigkeit", "vfzg", "vitesse", "vitessevehicule"),
    "lateral_acceleration": ("ay", "accy", "latacc", "lataccel", "lateralacceleration", "lateralaccel",
                             "accely", "ay1", "alat", "aylat", "accelerationy", "latg",
                             "querbeschleunigung", "querbeschl", "aquer", "accelerationlaterale", "acclat"),
    "yaw_rate": ("r", "yawrate", "yawrt", "wz", "gyroz", "omegaz", "yawvel", "yawvelocity", "psidot",
                 "angularvelocityz", "rz", "gierrate", "giergeschwindigkeit", "vitessedelacet", "vitesselacet",
                 "lacet"),
    "steering_wheel_angle": ("swa", "steerangle", "steeringangle", "steeringwheelangle", "steer", "swangle",
                             "strwhlang", "steeringwheel", "stwangle", "steerwheelangle", "handwheelangle",
                             "lenkradwinkel", "lenkwinkel", "anglevolant", "angledevolant"),
    "road_wheel_angle": ("deltaf", "delta", "roadwheelangle", "wheelangle", "rwa", "frontwheelangle"),
    "roll_rate": ("p", "rollrate", "rollrt", "wx", "gyrox", "omegax", "rollvel", "rollvelocity", "phidot",
                  "angularvelocityx", "rx", "wankrate", "wankgeschwindigkeit", "vitessederoulis", "roulis"),
    "pitch_rate": ("q", "pitchrate", "pitchrt", "wy", "gyroy", "omegay", "pitchvel", "pitchvelocity", "thetadot",
                   "angularvelocityy", "ry", "nickrate", "nickgeschwindigkeit", "vitessedetangage", "tangage"),
    "longitudinal_acceleration": ("ax", "accx", "longacc", "lonacc", "longaccel", "lngacc", "longitudinalacceleration",
                                  "longitudinalaccel", "accelx", "alon", "alng", "accelerationx", "longg",
                                  "laengsbeschleunigung", "langsbeschleunigung", "alaengs", "laengsbeschl",
                                  "langsbeschl",
                                  "accelerationlongitudinale", "acclong"),
    # a GNSS position, for `roadbank map`
    "latitude": ("lat", "latitude", "gpslat", "gnsslat", "latdeg", "poslat", "breite", "breitengrad"),
    "longitude": ("lon", "lng", "longitude", "gpslon", "gnsslon", "londeg", "poslon", "laengengrad", "langengrad"),
}
#: the GNSS roles :func:`guess_channels` looks for by name (for ``roadbank map``), and the largest magnitude (deg) of
#: each on the Earth
POSITION_LIMITS_DEG = {"latitude": 90.0, "longitude": 180.0}
#: above this 99th percentile of its magnitude a roll rate is not in rad/s (roads roll the body at 0.01-0.2 rad/s)
#: and a longitudinal acceleration not in g (braking and grades: 0.05-0.4 g)
OPTIONAL_RANGE = {"roll_rate": ("rad/s", "deg/s", 0.5), "longitudinal_acceleration": ("g", "m/s^2", 0.6),
                  "pitch_rate": ("rad/s", "deg/s", 0.5)}
#: unit hints found in a column name (after the role's spelling) -> unit
UNIT_HINTS = {"kmh": "km/h", "kph": "km/h", "mph": "mph", "mps": "m/s", "ms2": "m/s^2", "mss": "m/s^2",
              "degps": "deg/s", "degs": "deg/s", "dps": "deg/s", "rads": "rad/s", "radps": "rad/s",
              "deg": "deg", "rad": "rad", "ms": "ms", "us": "us", "ns": "ns", "sec": "s", "g": "g"}
#: wheelbase (m) for the kinematic steering check (any car: 2.4-3.2 m)
WHEELBASE_M = 2.7
#: the slope of ay on vx r may be this far from :data:`SLOPE_MID` and still choose the units (a factor, -)
PHYSICS_TOL = 4.0
#: the slopes of ay on vx r (-) real roads give over turns: 1 on a flat road, lower in a banked curve (the
#: bank carries part of the turn), higher with the body's roll; read as :func:`_fit` does, 0.76-1.17 on the 14
#: shared KITTI drives with turns enough, 0.97-1.02 there once the INS roll is taken out
SLOPE_BAND = (0.7, 1.3)
#: the band's (geometric) middle: the units whose slope lies nearest it are chosen
SLOPE_MID = math.sqrt(SLOPE_BAND[0] * SLOPE_BAND[1])
#: yaw rate (rad/s) and speed (m/s) above which a sample counts as in a turn
TURN_R, TURN_V = 0.03, 5.0
#: the slope is read over the stronger half (by ``|vx r|``) of the turning samples faster than this share of the
#: log's 95th-percentile speed (a share: the same samples whatever the speed's unit); a bank of a few degrees
#: weighs little in strong turns. Only where their RMS ``|vx r|`` is at least :data:`STRONG_TURN` (m/s^2) can a
#: unit be ``high``
MOVING_SHARE, STRONG_TURN = 0.2, 1.0
#: turning samples needed to read the slope at all
MIN_TURNS = 20
#: what separates a CAN message (or a device) from its signal in a logger's column name: ``ESP_21.LatAcc``,
#: ``ESP_LatAcc``, ``IMU:RollRate``, ``ESP/YawRate``, ``ESP LatAcc`` (only before a unit in brackets: ``[km/h]``)
PREFIX_SEPARATORS = "_.:/ "
#: words that put a prefix's signal on another part of the car than its body (``Engine_Speed``, ``Wheel_Speed``,
#: ``Lenkrad_Geschwindigkeit``: the steering wheel's): such a name is not matched after its prefix
OTHER_PARTS = ("engine", "motor", "wheel", "whl", "lenk", "gear", "pedal")
#: what a map without a steering channel means
NO_STEERING = ("the map has none, and the log is read with the steering angle absent (NaN), as a KITTI drive is: "
               "the default estimator kinematic-pif does not read it; dfc, uio, pio-original, pif-original and "
               "kalman give no valid sample")
#: what the guess says of the overall sign convention: the data fix the signs relative to each other only
ASSUMED_SIGN = "positive to the left assumed (ISO 8855): the data cannot tell (see convention)"
#: the comment on the guessed map's ``convention`` (and the line ``roadbank channels`` prints)
CONVENTION_NOTE = ("the sign convention cannot be told from the data and is assumed ISO 8855: ay positive to the "
                   "left, yaw rate and steering counter-clockwise positive. A log whose ay, yaw rate and steering "
                   "are all positive to the right balances ay = vx r alike: for one, write convention = \"FRD\"")


def _norm(name: str) -> str:
    """A column name as :data:`NAMES` spells it: lower case, letters and digits only, accents dropped (``é`` ->
    ``e``, ``ä`` -> ``a``)."""
    bare = unicodedata.normalize("NFKD", name).encode("ascii", "ignore").decode()
    return re.sub(r"[^a-z0-9]", "", bare.lower())


def _tokens(name: str) -> list[str]:
    """``"VehSpd_kmh"`` -> ``["veh", "spd", "kmh"]`` (camel case and separators split)."""
    parts = re.sub(r"([a-z0-9])([A-Z])", r"\1 \2", name)
    return [p for p in re.split(r"[^A-Za-z0-9]+", parts.lower()) if p]


@dataclass
class Guess:
    """One guessed channel.

    Attributes
    ----------
    role : str
        Channel-map role (``time``, ``speed``, ...).
    column : str or None
        The column; None if none was found.
    unit : str
        Its unit.
    invert : bool
        Its sign is opposite to ISO 8855 (``invert = true`` in the map).
    confidence : str
        "high", "medium" or "low".
    reason : str
        What the guess rests on, in words.
    """

    role: str
    column: str | None
    unit: str = ""
    invert: bool = False
    confidence: str = "low"
    reason: str = ""


def name_match(role: str, name: str) -> tuple[int, str | None]:
    """(score, unit hint) of column ``name`` for ``role``: 2 = a known spelling, 1 = one with a
    unit or other suffix (``VehSpd_kmh``, ``yaw_rate_dps``) or a known spelling after a message prefix
    (``ESP_21.LatAcc``, ``ESP_YawRate``, ``IMU_RollRate``: :func:`_after_prefix`), 0 = no match."""
    score, hint = _bare_match(role, name)
    if score == 0 and (tail := _after_prefix(name)) is not None and tail[0] == role:
        return 1, tail[1]
    return score, hint


def named_as(role: str, name: str) -> bool:
    """Whether column ``name`` is a known spelling of ``role``: alone (``roll_rate``, ``gyro_x``, ``RollRate``), with a
    unit in it (``roll_rate_dps``) or after a message's or a device's prefix (``IMU.RollRate``) -- not a longer word
    that only starts with one (``RollRateQuality``, which :func:`name_match` ranks 1 as well). What a log read without
    a channel map needs of a column to read it as an optional channel (:mod:`roadbank.io.mapchoice`)."""
    score = _bare_match(role, name)[0]
    if score == 2:
        return True
    tail = _after_prefix(name) if score == 0 else None
    return tail is not None and tail[0] == role


@functools.lru_cache(maxsize=4096)
def _after_prefix(name: str) -> tuple[str, str | None] | None:
    """(role, unit hint) of a column ``name`` that is a message prefix, a separator (:data:`PREFIX_SEPARATORS`) and a
    known spelling of one role (``ESP_21.VehSpeed[km/h]`` -> speed, km/h); None for any other name.

    The shortest prefix whose rest is a spelling counts, and only one that names no role itself (``LatAcc_YawRate``
    could be either: it stays the ay its start says, as without prefixes) nor another part of the car
    (:data:`OTHER_PARTS`); the rest must be more than one letter (``Brake_p`` is a pressure) and a spelling of one
    role only."""
    head = re.split(r"[\[(]", name, maxsplit=1)[0]
    for i, ch in enumerate(head):
        if ch not in PREFIX_SEPARATORS or i == 0:
            continue
        prefix, rest = name[:i], name[i + 1:]
        found = [(role, hint) for role in NAMES for score, hint in [_bare_match(role, rest)] if score == 2]
        if not found:
            continue
        p = _norm(prefix)
        if (len(found) > 1 or len(_norm(head[i + 1:])) < 2 or any(w in p for w in OTHER_PARTS)
                or any(_bare_match(role, prefix)[0] for role in NAMES)):
            return None
        return found[0]
    return None


def _bare_match(role: str, name: str) -> tuple[int, str | None]:
    """:func:`name_match` of the whole ``name``, no prefix taken off."""
    n = _norm(name)
    spellings = NAMES[role]
    if n in spellings:
        return 2, None
    for s in sorted(spellings, key=len, reverse=True):
        if len(s) >= 2 and n.startswith(s):
            rest = n[len(s):]
            if rest in UNIT_HINTS:
                return 2, UNIT_HINTS[rest]
            if len(s) >= 4:
                return 1, None
    toks = _tokens(name)
    if len(toks) > 1 and _norm("".join(toks[:-1])) in spellings and toks[-1] in UNIT_HINTS:
        return 2, UNIT_HINTS[toks[-1]]
    return 0, None


def _finite(v: np.ndarray) -> np.ndarray:
    return v[np.isfinite(v)]


def _time_unit(t: np.ndarray, hint: str | None) -> tuple[str | None, str, bool]:
    """(unit, why, name and data agree) of a time column from its median sample period (an ESP log: 1-200 ms)."""
    d = np.diff(_finite(t))
    d = d[d > 0]
    if len(d) == 0:
        return None, "not increasing", False
    dt = float(np.median(d))
    fits = [u for u, f in FACTORS["time"].items() if 5e-4 <= dt * f <= 0.2]
    if hint in fits:
        return hint, f"unit in the name and sample period agree ({dt:g} {hint})", True
    if fits:
        return fits[0], f"sample period {dt:g} {fits[0]}", False
    return None, f"median step {dt:g}: no plausible unit", False


def _is_increasing(v: np.ndarray) -> bool:
    f = _finite(v)
    return len(f) > 2 and float(np.mean(np.diff(f) > 0)) > 0.9


#: candidate units (and SI factors) per role, for the physics checks
_CAND = {"speed": FACTORS["speed"], "lateral_acceleration": {"m/s^2": 1.0, "g": FACTORS["acceleration"]["g"]},
         "yaw_rate": FACTORS["angular_rate"]}


def _range_units(role: str, v: np.ndarray) -> list[str]:
    """Units in which the values of ``role`` are plausible for a road car."""
    a = np.abs(_finite(v))
    if len(a) == 0 or not a.max() > 0:
        return []                      # nothing to judge a unit by
    mx, p99 = float(a.max()), float(np.percentile(a, 99))
    if role == "speed":
        return [u for u in ("m/s", "km/h", "mph") if mx * FACTORS["speed"][u] <= 70.0 and u != "kph"]
    if role == "lateral_acceleration":
        return [u for u in ("m/s^2", "g") if p99 * _CAND[role][u] <= 15.0 and (u != "g" or p99 > 0.005)]
    if role == "yaw_rate":
        return [u for u in ("rad/s", "deg/s") if p99 * FACTORS["angular_rate"][u] <= 1.5
                and (u != "deg/s" or p99 > 0.05)]
    return []


def guess_channels(names: list[str], data: dict[str, np.ndarray], times: dict | None = None,
                   stated: dict[str, str] | None = None) -> list[Guess]:
    """Guess the roadbank channels of a log with columns ``names`` and numeric ``data`` (column -> array).

    Parameters
    ----------
    names : list of str
        Every column of the file.
    data : dict column -> float array
        The numeric columns (as stored), all of one length on one clock, unless ``times``.
    times : dict column -> array (s), optional
        Per-channel time stamps (MDF4): no ``time`` role is guessed then, and the physics checks
        interpolate onto the yaw rate's stamps.
    stated : dict column -> str, optional
        The units the file states (a CSV's units row, an MDF4 channel's unit): where one is a unit of the role's
        kind it stands for the column's unit as a unit in its name does, and wins over one (:func:`stated_hint`).

    Returns
    -------
    list of Guess
        time (unless ``times``), speed, lateral_acceleration, yaw_rate and one steering role (its column None
        when the log has no steering angle: :data:`NO_STEERING`), then each optional role
        (:data:`roadbank.io.channels.OPTIONAL`) that a column is named like: by name alone, never by elimination,
        its unit by the name or the range (the default checks each against the ESP channels before it uses it).
    """
    numeric = [c for c in names if c in data and np.isfinite(data[c]).any()]
    used: set[str] = set()
    from_file: set[str] = set()        # the columns whose unit hint is one the file states
    out: dict[str, Guess] = {}

    def pick(role, pool, extra=None):
        best = max(((name_match(role, c), c) for c in pool if c not in used), key=lambda x: x[0][0],
                   default=((0, None), None))
        (score, hint), col = best
        if score == 0:
            col = extra([c for c in pool if c not in used]) if extra is not None else None
        if col is not None:
            used.add(col)
            said = stated_hint(role, (stated or {}).get(col))
            if said is not None:
                hint = said
                from_file.add(col)
        return col, score, hint

    hints = {}
    scores = {}
    if not times:
        col, score, hint = pick("time", numeric, lambda pool: next((c for c in pool if _is_increasing(data[c])),
                                                                   None))
        if col is None:
            out["time"] = Guess("time", None, reason="no column named like a time and none increasing")
        else:
            unit, why, agree = _time_unit(data[col], hint)
            conf = "high" if score and unit else "low"
            out["time"] = Guess("time", col, unit or "s", False, conf,
                                why if agree else (("name and " if score else "increasing; ") + why
                                                   + (" agree" if score and unit else "")))
    for role in ("speed", "lateral_acceleration", "yaw_rate"):
        col, scores[role], hints[role] = pick(role, numeric)
        out[role] = Guess(role, col)
    swcol, sws, swh = pick("steering_wheel_angle", numeric)
    rwcol, rws, rwh = pick("road_wheel_angle", numeric) if swcol is None else (None, 0, None)
    steer_col, steer_named = (swcol, "steering_wheel_angle") if swcol else (rwcol, "road_wheel_angle")
    steer_hint = swh if swcol else rwh
    empty = [c for c in names if c not in numeric and c not in used
             and any(name_match(k, c)[0] for k in STEERING)]

    def series(col):
        if col is None:
            return None
        if not times:
            return data[col]
        base = times.get(out["yaw_rate"].column) if out["yaw_rate"].column else None
        return data[col] if base is None else np.interp(base, times[col], data[col])

    v, a, r = (series(out[k].column) for k in ("speed", "lateral_acceleration", "yaw_rate"))
    _units_from_physics(out, v, a, r, hints, scores)
    out_steer = _steering(steer_col, steer_named, steer_hint, series(steer_col), v, r, out)
    if steer_col is None and empty:
        out_steer.reason = f"column {empty[0]!r} is named like a steering angle but holds no numbers"
    roles = (["time"] if "time" in out else []) + ["speed", "lateral_acceleration", "yaw_rate"]
    optional = []
    for role in OPTIONAL:
        col, score, hint = pick(role, numeric)
        optional.append(_optional(role, col, score, hint, series))
    positions = []
    for role in POSITION_LIMITS_DEG:
        col, score, _ = pick(role, numeric)
        positions.append(_position(role, col, score, series))
    guesses = [out[k] for k in roles] + [out_steer] + [g for g in optional + positions if g is not None]
    for g in guesses:        # a unit the file states is the one that counted as the name's
        if g.column in from_file:
            g.reason = g.reason.replace("unit in the name", "unit the file states")
    return guesses


def stated_hint(role: str, unit: str | None) -> str | None:
    """The unit a file states for a column of ``role`` (``unit`` as written, None if none), spelled as a channel map
    declares it, where it is one of the role's kind (:data:`roadbank.units.FACTORS`); else None."""
    if unit is None:
        return None
    u = normalise_unit(unit)
    return u if u in FACTORS[ROLES[role][0]] else None


def _optional(role: str, col, score: int, hint, series) -> Guess | None:
    """The guess of an optional role for the column ``col`` named like it (``score`` of :func:`name_match`, its unit
    ``hint``); ``series(col)`` its values. None when no column is named like it."""
    if col is None or score == 0:
        return None
    small, large, limit = OPTIONAL_RANGE[role]
    a = np.abs(_finite(series(col)))
    if hint in (small, large):
        unit, why = hint, "name, unit in the name"
    elif len(a):
        p99 = float(np.percentile(a, 99))
        unit = small if p99 <= limit else large
        why = f"name, range (99th percentile {p99:.3g}: {unit})"
    else:
        unit, why = small, f"name; no values to judge the unit by: {small} assumed"
    return Guess(role, col, unit, False, "medium", f"{why}; optional, sign not checked here: the default uses it "
                 "only where it follows the ESP channels")


def _position(role: str, col, score: int, series) -> Guess | None:
    """The guess of a GNSS ``role`` (latitude, longitude) for the column ``col`` named like it (``score`` of
    :func:`name_match`): in deg, where its values lie within the Earth's (:data:`POSITION_LIMITS_DEG`); None when no
    column is named like it or its values cannot be degrees (a scaled integer: say it by hand)."""
    if col is None or score == 0:
        return None
    a = np.abs(_finite(series(col)))
    if len(a) and float(a.max()) > POSITION_LIMITS_DEG[role]:
        return None
    return Guess(role, col, "deg", False, "medium", "name, range within the Earth's; in degrees (`roadbank map` "
                 "refuses positions that move far less or more than the speed drives, as radians read as degrees do)")


@dataclass(frozen=True)
class _Fit:
    """The balance ``ay = vx r`` under one choice of units (speed, ay, yaw rate)."""

    units: tuple[str, str, str]
    slope: float         #: |least-squares slope of ay on vx r| over the turns read (-)
    corr: float          #: correlation of ay with vx r there (its sign: the yaw rate's against ay's)
    strong: bool         #: the turns read are strong (RMS |vx r| >= STRONG_TURN), not only gentle ones

    @property
    def miss(self) -> float:
        """How far the slope is from the middle of :data:`SLOPE_BAND` (log ratio, >= 0)."""
        return abs(math.log(max(self.slope, 1e-9) / SLOPE_MID))

    @property
    def fits(self) -> bool:
        return SLOPE_BAND[0] <= self.slope <= SLOPE_BAND[1]


_PHYS_ROLES = ("speed", "lateral_acceleration", "yaw_rate")


def _fit(units: tuple[str, str, str], v: np.ndarray, a: np.ndarray, r: np.ndarray, moving: np.ndarray) -> _Fit | None:
    """The slope of ay on vx r with the stored ``v``, ``a``, ``r`` read in ``units``, over the stronger half (by
    ``|vx r|``) of the ``moving`` samples that turn; None with fewer than :data:`MIN_TURNS` of them.

    The samples do not depend on the speed's unit (``moving`` is relative to the log's own speeds), so the
    slopes of two speed units differ by their factor exactly."""
    vs = v * _CAND["speed"][units[0]]
    as_ = a * _CAND["lateral_acceleration"][units[1]]
    rs = r * _CAND["yaw_rate"][units[2]]
    turn = moving & (np.abs(rs) > TURN_R)
    if turn.sum() < MIN_TURNS:
        return None
    pred = vs * rs
    sel = turn & (np.abs(pred) >= np.median(np.abs(pred[turn])))
    p, y = pred[sel], as_[sel]
    gain = float(np.dot(y, p) / max(float(np.dot(p, p)), 1e-300))
    corr = float(np.corrcoef(y, p)[0, 1]) if np.std(p) > 0 and np.std(y) > 0 else 0.0
    return _Fit(units, abs(gain), corr, float(np.sqrt(np.mean(p * p))) >= STRONG_TURN)


def _units_from_physics(out, v, a, r, hints, scores) -> None:
    """Units of speed, ay and yaw rate (ranges, name hints, ``ay = vx r`` in turns) and the yaw rate's sign.

    Every combination of the units each channel's range allows (speed: m/s, km/h, mph) is tried; the one whose
    slope of ay on vx r lies nearest the middle of :data:`SLOPE_BAND` is chosen, or, among those inside the
    band, the one the unit hints in the names agree with. A unit is ``high`` only when no other unit of its
    channel gives a slope inside the band (km/h and mph differ by 1.61 only, the band spans 1.86) over strong
    turns, or the name states it.
    """
    cand, blind = {}, set()
    for role, x in zip(_PHYS_ROLES, (v, a, r)):
        g = out[role]
        if x is None:
            g.reason = "no column named like it"
            continue
        units = _range_units(role, x)
        if not units:
            blind.add(role)
            units = list(_CAND[role])[:1]
        cand[role] = units
    fits: list[_Fit] = []
    if v is not None and a is not None and r is not None:
        ok = np.isfinite(v) & np.isfinite(a) & np.isfinite(r)
        vo = v[ok]
        moving = vo > MOVING_SHARE * (float(np.percentile(vo, 95)) if len(vo) else 0.0)
        for uv, ua, ur in itertools.product(*(cand[k] for k in _PHYS_ROLES)):
            f = _fit((uv, ua, ur), vo, a[ok], r[ok], moving)
            if f is not None:
                fits.append(f)
    in_band = [f for f in fits if f.fits]
    hinted = [f for f in in_band if all(hints.get(k) in (None, u) for k, u in zip(_PHYS_ROLES, f.units))]
    best = min(hinted or fits, key=lambda f: f.miss, default=None)
    if best is not None and best.miss >= math.log(PHYSICS_TOL):
        best = None
    band = f"{SLOPE_BAND[0]:g}-{SLOPE_BAND[1]:g}"
    for i, (role, x) in enumerate(zip(_PHYS_ROLES, (v, a, r))):
        g = out[role]
        if x is None:
            continue
        hint = hints.get(role)
        units = cand[role]
        named = scores.get(role, 0) > 0
        if best is not None:
            unit = best.units[i]
            g.unit = unit
            rivals: dict[str, _Fit] = {}        # the other units of this channel that fit, each with its best fit
            for f in sorted(in_band, key=lambda f: f.miss):
                if f.units[i] != unit:
                    rivals.setdefault(f.units[i], f)
            nxt = min((f for f in fits if f.units[i] != unit), key=lambda f: f.miss, default=None)
            phys = f"ay = vx r in turns (slope {best.slope:.2f} in {unit})"
            named_unit = "unit in the name, " if hint == unit else ""
            if hint is not None and hint != unit:
                g.confidence = "low"
                g.reason = f"{phys} says {unit}, the name says {hint}"
            elif rivals and hint == unit:
                g.confidence = "high"
                g.reason = (f"name, unit in the name and {phys} agree; the slope alone would not tell it from "
                            + " or ".join(rivals))
            elif rivals:
                g.confidence = "low"
                other = " or ".join(f"{u} (slope {f.slope:.2f})" for u, f in rivals.items())
                g.reason = (f"ay = vx r in turns cannot tell {unit} (slope {best.slope:.2f}) from {other}: "
                            f"both within {band}, the slopes real roads give; {unit} is nearer their middle "
                            f"{SLOPE_MID:.2f} -- check the unit")
            elif not best.fits:
                g.confidence = "medium" if named else "low"
                g.reason = (("name and " if named else "") + f"{phys} nearest in {unit}, but the slope is "
                            f"outside {band}, the slopes real roads give")
            elif not best.strong:
                g.confidence = "medium" if named else "low"
                g.reason = (("name, " if named else "") + named_unit + f"range and {phys} agree, "
                            f"but over gentle turns only (RMS |vx r| below {STRONG_TURN:g} m/s^2)")
            else:
                g.confidence = "high" if named else "medium"
                clear = (f"ay = vx r in turns agree (slope {best.slope:.2f} in {unit}"
                         + (f"; {nxt.units[i]}: {nxt.slope:.2f}" if nxt is not None else "")
                         + f"; no other unit within {band})")
                g.reason = ("name, " if named else "") + named_unit + "range and " + clear
        else:
            unit = hint if hint in units else units[0]
            g.unit = unit
            single = len(units) == 1 and role not in blind
            g.confidence = "medium" if named and (single or hint == unit) else "low"
            if role in blind:
                g.reason = ("name" if named else "no name match") + f"; no values to judge the unit by: {unit} assumed"
                continue
            g.reason = (("name" if named else "no name match") + (", unit in the name" if hint == unit else "")
                        + (", range only fits " + unit if single else f", range fits {' or '.join(units)}")
                        + ("" if fits else "; too few turns to check ay = vx r"))
    if a is not None:
        out["lateral_acceleration"].reason += f"; sign: {ASSUMED_SIGN}"
    if best is not None and abs(best.corr) > 0.5:
        g = out["yaw_rate"]
        if best.corr < 0:
            g.invert = True
            g.reason += (f"; sign opposite to ay's in turns (correlation {best.corr:.2f}): inverted, so "
                         "counter-clockwise positive if ay is positive to the left (assumed)")
        else:
            g.reason += (f"; sign the same as ay's in turns (correlation {best.corr:.2f}), so counter-clockwise "
                         "positive if ay is positive to the left (assumed)")
    else:
        out["yaw_rate"].reason += "; sign not checked (no clear turn): ISO assumed"


def _steering(col, named_role, hint, x, v, r, out) -> Guess:
    """Road-wheel or steering-wheel angle, its unit and sign, against the kinematic ``L r / vx``."""
    if col is None:
        return Guess("steering_wheel_angle", None, reason="no column named like a steering angle")
    a = np.abs(_finite(x))
    ok = v is not None and r is not None and out["speed"].unit and out["yaw_rate"].unit
    if ok:
        vs = v * FACTORS["speed"][out["speed"].unit]
        rs = r * FACTORS["angular_rate"][out["yaw_rate"].unit] * (-1.0 if out["yaw_rate"].invert else 1.0)
        turn = np.isfinite(x) & np.isfinite(vs) & np.isfinite(rs) & (np.abs(rs) > TURN_R) & (vs > TURN_V)
        ok = turn.sum() >= 20
    if ok:
        kin = WHEELBASE_M * rs[turn] / vs[turn]
        ratio = float(np.median(np.abs(x[turn])) / max(np.median(np.abs(kin)), 1e-9))
        corr = float(np.corrcoef(x[turn], kin)[0, 1]) if np.std(x[turn]) > 0 else 0.0
        cands = {("road_wheel_angle", "rad"): 1.0, ("road_wheel_angle", "deg"): 180 / math.pi,
                 ("steering_wheel_angle", "rad"): 16.0, ("steering_wheel_angle", "deg"): 16.0 * 180 / math.pi}
        dist = {k: abs(math.log(max(ratio, 1e-9) / f)) for k, f in cands.items()}
        by_size = min(dist, key=lambda k: dist[k])
        # the name tells road wheel from steering wheel (understeer can make a road-wheel angle several
        # times the kinematic one); the size then tells deg from rad (a factor 57)
        role, unit = min((k for k in dist if k[0] == named_role), key=lambda k: dist[k])
        fits_name = by_size == (role, unit) and hint in (None, unit)
        sure = abs(corr) > 0.5
        g = Guess(role, col, unit, sure and corr < 0, "high" if fits_name and sure else "medium",
                  f"{'name and ' if fits_name else ''}size against the kinematic angle L r / vx "
                  f"(x{ratio:.1f}) agree" if fits_name else
                  f"name says {role.replace('_', ' ')}, size against the kinematic angle L r / vx (x{ratio:.1f}) "
                  f"fits {unit} best for it ({by_size[0].replace('_', ' ')} in {by_size[1]} overall)")
        g.reason += ("; sign not checked (no clear turn): ISO assumed" if not sure else
                     f"; sign opposite to the yaw rate's (correlation {corr:.2f}): inverted" if corr < 0
                     else f"; sign the same as the yaw rate's (correlation {corr:.2f})")
        return g
    unit = hint or ("deg" if len(a) and float(a.max()) > 2 * math.pi else "rad")
    return Guess(named_role, col, unit, False, "low", "name and range only (too few turns to check)")


def channel_map_toml(guesses: list[Guess], source: str) -> str:
    """The guessed channel map as TOML text (loads with :func:`roadbank.io.read_channel_map`), one
    comment per channel saying how sure the guess is; channels not found are left as comments."""
    lines = [f"# channel map guessed by `roadbank channels` from {source}",
             "# check every line: the confidence and the evidence are in the comments", "",
             *_comment(CONVENTION_NOTE), 'convention = "ISO"', "", "[channels]"]
    for g in guesses:
        if g.column is None and g.role in STEERING:
            lines += _comment(f"no steering channel ({g.reason}): {NO_STEERING}. If the log has one, add it, "
                              'e.g. steering_wheel_angle = { column = "...", unit = "deg" }')
            continue
        if g.column is None:
            lines.append(f'# {g.role} = {{ column = "?", unit = "?" }}   # not found: {g.reason}')
            continue
        inv = ", invert = true" if g.invert else ""
        lines.append(f"# {g.confidence}: {g.reason}")
        lines.append(f"{g.role} = {{ column = {_toml_str(g.column)}, unit = \"{g.unit}\"{inv} }}")
    return "\n".join(lines) + "\n"


def _comment(text: str, width: int = 110) -> list[str]:
    """``text`` as TOML comment lines."""
    return ["# " + line for line in textwrap.wrap(text, width)]


def _toml_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'
