"""The channel map a table log (CSV, Parquet, MDF4) is read with when the user gives none.

roadbank's default map (:func:`~roadbank.io.channels.default_channel_map`: columns ``t, vx, ay, r``, SI) names
roadbank's own columns. A log whose columns are named otherwise is read with the map
:func:`~roadbank.io.guess.guess_channels` guesses from the columns' names and data, where that guess is sure
(:func:`choose_map`, the one place every command and :func:`~roadbank.io.load_log` /
:func:`~roadbank.io.stream.stream_log` choose the map of a log given without one):

* **a required column the default map does not find** (``t``, ``vx``, ``ay`` or ``r``): the log is read with the
  guessed map where every required channel's guess is ``high`` (:data:`SURE`: time named like one at a plausible
  sample period; speed, ``ay`` and yaw rate named like themselves, with units for which ``ay = vx r`` holds over
  strong turns and no other unit of theirs would; the yaw rate's sign from the same turns). A ``medium`` guess (turns
  too gentle to check the units, or a slope outside the band real roads give) or a ``low`` one is not used: the log
  fails as before, the message naming what the guess found and why it was not trusted. A guessed steering angle is
  read only where it is ``high`` too (the default estimator does not read it); a roll rate, longitudinal
  acceleration or pitch rate, and a GNSS position, where named so (:func:`~roadbank.io.guess.named_as`).
* **the default map finds its required columns**, but the file has no ``p`` (``ax``, ``q``) and a column named like
  a roll rate (longitudinal acceleration, pitch rate) by a known spelling (``roll_rate``, ``gyro_x``, ``RollRate``,
  ``IMU.RollRate``, ``roll_rate_dps``): the default map reads it, in the unit the guess gives (the name's, else the
  range's). The estimator's own check of a roll rate (it must follow the roll that ``ay`` shows) still decides
  whether it is used. So is a GNSS position (for ``roadbank map``): a column named like a latitude and one named like
  a longitude (``lat``/``lon``, ``gps_lat``...), both, in deg, where both lie within the Earth's
  (:data:`~roadbank.io.guess.POSITION_LIMITS_DEG`) in the rows guessed; one alone is not read, a pair that is not
  degrees is not read and said (:func:`_positions`). And a steering angle, where the file has none of the default
  map's steering columns but one named like it (``SWA``, ``steer_deg``): read where its guess is ``high`` and was made
  against the speed and yaw rate as the default map reads them; else left out (NaN, as before) with a warning that
  says why (:func:`_steering`).

Either way a warning says which columns were taken, in which unit and sign, and how to pin the map
(``roadbank channels LOG -o map.toml``, then ``--channels map.toml``). The guess reads the file's columns named like
a channel (never one starting with the default map's truth prefix ``true_``), their first :data:`GUESS_ROWS` rows (an
MDF4 channel: samples), whether the log is then read whole or streamed: both read it with the same map.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from . import readers
from .assemble import STEERING_NAN, missing_column
from .channels import GUESSED_MAP_SOURCE, OPTIONAL, STEERING, ChannelMap, ChannelSpec
from .guess import NAMES, POSITION_LIMITS_DEG, Guess, guess_channels, name_match, named_as, stated_hint

#: the rows of a table (samples of an MDF4 channel) the guess reads from the log's start: 33 min at 100 Hz, more
#: than most logs hold; a longer log's guess reads its start, as the same map then reads the whole of it
GUESS_ROWS = 200_000
#: the formats whose columns are guessed (those ``roadbank channels`` guesses a map for)
GUESSED_FORMATS = ("csv", "parquet", "mdf4")
#: the confidence every required channel's guess must have for a log to be read with it
SURE = "high"
#: the :attr:`ChannelMap.source` of a guessed map
#: the required roles of a table, in the order a missing one is named (a channel source: no time)
_REQUIRED = ("speed", "lateral_acceleration", "yaw_rate", "time")


def choose_map(src, fmt: str, default: ChannelMap) -> tuple[ChannelMap | None, list[str]]:
    """The map to read ``src`` (a table source of :mod:`roadbank.io.sources` opened with the ``default`` map) with,
    and the warnings that say so: ``(None, [])`` where the default map reads it as it is; a guessed map where the
    default map misses a required column and the guess is sure; the default map with an optional channel added where
    the file has one under another name (see the module doc). LogError, naming the file, the missing column and what
    the guess found, where the default map misses a required column and the guess is not sure."""
    if fmt not in GUESSED_FORMATS:
        return None, []
    p, names = src.path, list(src.names)
    have = set(names)
    roles = [r for r in _REQUIRED if r != "time" or src.shared_clock]
    missing = [r for r in roles if default.channels[r].column not in have]
    if missing:
        if any(str(n).startswith("CAN_DataFrame") for n in names):
            return None, []             # an MDF4 bus log: the assembler's message asks for a DBC
        return _guessed(p, fmt, names, default, missing[0], roles)
    cols = [c for c in names if not _truth(default, c)]
    extra = [r for r in OPTIONAL if default.channels[r].column not in have and any(named_as(r, c) for c in cols)]
    gnss = not set(POSITION_LIMITS_DEG) & set(default.channels) and all(
        any(named_as(r, c) for c in cols) for r in POSITION_LIMITS_DEG)
    steer = [r for r in STEERING if r in default.channels]
    steering = (bool(steer) and not any(default.channels[r].column in have for r in steer)
                and any(named_as(r, c) for r in STEERING for c in cols))
    if not (extra or gnss or steering):
        return None, []
    head = _guess(p, fmt, names, default, wanted={default.channels[r].column for r in roles})
    channels, notes = dict(default.channels), []
    for g in head.guesses:
        if g.role in extra and g.column is not None and named_as(g.role, g.column):
            channels[g.role] = ChannelSpec(g.role, g.column, g.unit)
            notes.append(f"{p}: channel '{g.role}' (column '{g.column}'): read as the {_words(g.role)} in {g.unit}, "
                         f"sign as stored (the default channel map's column '{default.channels[g.role].column}' is "
                         f"not in the file, and this one is named like it){_USE[g.role]} -- to pin it or leave it "
                         f"out: {_pin(p)}")
    if gnss:
        specs, said = _positions(p, head)
        channels.update(specs)
        notes += [f"{p}: channels 'latitude', 'longitude' (columns '{specs['latitude'].column}', "
                  f"'{specs['longitude'].column}'): read as a GNSS position in deg (the default channel map has none, "
                  "and these are named like one, within the Earth's +-90 and +-180 deg in the first rows) for "
                  "`roadbank map`, which refuses positions that do not move as the speed drives -- to pin it or "
                  f"leave it out: {_pin(p)}"] if specs else said
    if steering:
        spec, said = _steering(p, head, default, steer)
        if spec is not None:
            channels = {r: c for r, c in channels.items() if r not in STEERING}
            channels[spec.role] = spec
        notes += said
    return (replace(default, channels=channels), notes) if channels != default.channels else (None, notes)


def _positions(p, head: _Head) -> tuple[dict[str, ChannelSpec], list[str]]:
    """The GNSS position of a log whose columns name one (a latitude and a longitude, each by a known spelling:
    :func:`~roadbank.io.guess.named_as`): both channels in deg where the guess took both (their values within the
    Earth's, :data:`~roadbank.io.guess.POSITION_LIMITS_DEG`, in the rows it read), with no warning (the caller says
    it); else none, and the warning that says which coordinate was not read and why (never half a position)."""
    by_role = {g.role: g for g in head.guesses}
    got = {r: g for r in POSITION_LIMITS_DEG if (g := by_role.get(r)) is not None and g.column is not None
           and named_as(r, g.column)}
    if len(got) == len(POSITION_LIMITS_DEG):
        return {r: ChannelSpec(r, g.column, g.unit) for r, g in got.items() if g.column is not None}, []
    why = []
    for role, limit in POSITION_LIMITS_DEG.items():
        if role in got:
            continue
        col = next((c for c in head.names if named_as(role, c)), None)
        if col is None:
            continue
        x = head.data.get(col)
        if col in head.unread:
            why.append(f"'{col}' is not read as numbers ({head.unread[col]})")
        elif x is None or not np.isfinite(x).any():
            why.append(f"'{col}' holds no number in the first rows")
        else:
            why.append(f"'{col}' reaches {float(np.nanmax(np.abs(x))):.6g}, beyond the {_words(role)}'s {limit:g} "
                       "deg (a scaled integer, or another unit)")
    cols = ", ".join(f"'{c}'" for c in head.names if any(named_as(r, c) for r in POSITION_LIMITS_DEG))
    return {}, [f"{p}: columns {cols} are named like a GNSS position, not read as one: {'; '.join(why)} -- to read "
                f"it: {_pin(p)}, with its unit"]


def _steering(p, head: _Head, default: ChannelMap, steer: list[str]) -> tuple[ChannelSpec | None, list[str]]:
    """The steering channel of a log the default map reads but for its steering (none of its columns ``steer`` in
    the file) and whose columns name one: the guess's, where it is :data:`SURE` and was made against the speed and
    yaw rate as the default map reads them (same columns, units and sign), with the warning that says so; else none,
    and the warning that says why (the steering angle then NaN, as :func:`~roadbank.io.assemble.steering_note`
    says)."""
    g = next((g for g in head.guesses if g.role in STEERING), None)
    if g is None or g.column is None or not named_as(g.role, g.column):
        return None, []
    by_role = {x.role: x for x in head.guesses}
    odd = [r for r in ("speed", "yaw_rate") if not _as_default(by_role.get(r), default, head.stated)]
    cols = " and ".join(f"'{default.channels[r].column}'" for r in steer)
    if g.confidence != SURE or odd:
        why = (f"its guess is {g.confidence} (not {SURE}: {g.reason})" if g.confidence != SURE else
               f"the guess checked it against a {' and a '.join(_words(r) for r in odd)} read otherwise than the "
               "default channel map reads them")
        return None, [f"{p}: channel '{g.role}' (column '{g.column}'): not read as the steering angle, {why} -- to "
                      f"read it: {_pin(p)}, check its unit and sign"]
    sign = "sign inverted: opposite to the yaw rate in turns" if g.invert else "sign as stored"
    return ChannelSpec(g.role, g.column, g.unit, invert=g.invert), [
        f"{p}: channel '{g.role}' (column '{g.column}'): read as the {_words(g.role)} in {g.unit}, {sign} (the "
        f"default channel map's columns {cols} are not in the file; this one is named like it and its guess is "
        f"{SURE}: {g.reason}): the default estimator does not read it, identify and the original-model filters do "
        f"-- to pin it or leave it out: {_pin(p)}"]


def _as_default(g: Guess | None, default: ChannelMap, stated: dict[str, str]) -> bool:
    """Whether the guess ``g`` of a required role reads its channel as the default map does: its column, the unit
    (the file's stated one where it states one, else the map's) and the sign as stored."""
    if g is None or g.column is None:
        return False
    spec = default.channels[g.role]
    unit = stated_hint(g.role, stated.get(spec.column)) or spec.unit
    return g.column == spec.column and g.unit == unit and not g.invert and not spec.invert


#: what the default does with an optional channel read by name (the end of its warning)
_USE = {"roll_rate": ": the gyro-aided default uses it only where it follows the roll that ay shows",
        "longitudinal_acceleration": ": the gyro-aided default reads the grade from it only where it follows the "
                                     "speed",
        "pitch_rate": ": the default does not read a pitch rate not documented free of offset (unbiased = true "
                      "in a map)"}


def _words(role: str) -> str:
    return role.replace("_", " ")


def _pin(p) -> str:
    """How to pin the map of log ``p``: write it, check it, give it."""
    return f"roadbank channels {Path(p).name} -o map.toml, then --channels map.toml"


def _truth(default: ChannelMap, column: str) -> bool:
    return bool(default.truth_prefix) and column.startswith(str(default.truth_prefix))


def _guessed(p, fmt: str, names: list[str], default: ChannelMap, first_missing: str,
             roles: list[str]) -> tuple[ChannelMap, list[str]]:
    """The guessed map of a log the default map misses ``first_missing`` of (a required role), with its warnings;
    LogError where the guess of a required role (``roles``) is not :data:`SURE`."""
    read = _guess(p, fmt, names, default)
    guesses, unread = read.guesses, read.unread
    by_role = {g.role: g for g in guesses}
    doubts = [r for r in roles if (g := by_role.get(r)) is None or g.column is None or g.confidence != SURE]
    if doubts:
        found = ", ".join(_found(by_role.get(r), r) for r in roles)
        why = (f"the guess from its columns' names and data is not sure enough to read it with (every one of "
               f"{', '.join(roles)} must be {SURE}): {found}"
               + "".join(f", column {c!r} not read as numbers ({w})" for c, w in unread.items()))
        raise missing_column(p, first_missing, default.channels[first_missing].column, names, guessed=why)
    channels: dict[str, ChannelSpec] = {}
    notes: list[str] = []
    taken: list[str] = []
    # a GNSS position (for `roadbank map`): both coordinates, each named like itself
    positions = all((g := by_role.get(r)) is not None and g.column is not None and named_as(r, g.column)
                    for r in POSITION_LIMITS_DEG)
    for g in guesses:
        if g.column is None:
            continue
        if g.role in STEERING and g.confidence != SURE:
            notes.append(f"{p}: channel '{g.role}' (column '{g.column}'): not read, its guess is {g.confidence} "
                         f"(not {SURE}), so the steering angle is NaN ({STEERING_NAN}) -- to read it: {_pin(p)}, "
                         "check its unit and sign")
            continue
        if g.role in OPTIONAL and not named_as(g.role, g.column):
            continue
        if g.role in POSITION_LIMITS_DEG and not positions:
            continue
        channels[g.role] = ChannelSpec(g.role, g.column, g.unit, invert=g.invert)
        taken.append(_said(g))
    if not any(r in channels for r in STEERING):
        taken.append("no steering angle (NaN, the default estimator does not read it)")
    if not positions and all(any(named_as(r, c) for c in names if not _truth(default, c))
                             for r in POSITION_LIMITS_DEG):
        notes += _positions(p, read)[1]
    cmap = ChannelMap(channels, truth_prefix=default.truth_prefix, source=GUESSED_MAP_SOURCE,
                      no_steering=not any(r in channels for r in STEERING))
    head = (f"{p}: no column '{default.channels[first_missing].column}' (the default channel map's "
            f"{_words(first_missing)}): read with the channel map guessed from its columns' names and data, every "
            f"required channel's guess {SURE} -- ")
    notes.insert(0, head + ", ".join(taken) + f" -- to pin it: {_pin(p)}")
    return cmap, notes


def _said(g: Guess) -> str:
    """One guessed channel as the warning names it: role, column, unit and sign."""
    if g.role == "time" or g.role in POSITION_LIMITS_DEG:
        how = g.unit
    elif g.role == "lateral_acceleration":
        how = f"{g.unit}, sign as stored: positive to the left assumed, ISO 8855, the data cannot tell"
    elif g.role in OPTIONAL:
        how = f"{g.unit}, sign as stored: used only where it follows the other channels"
    else:
        how = f"{g.unit}, sign {'inverted: opposite to ay in turns' if g.invert else 'as stored'}"
    return f"{g.role} <- '{g.column}' ({how})"


def _found(g: Guess | None, role: str) -> str:
    """What the guess found for ``role``, for the error: the column, unit and confidence, and why where not sure."""
    if g is None or g.column is None:
        return f"{role}: not found ({g.reason if g is not None else 'no column named like it'})"
    inv = ", inverted" if g.invert else ""
    why = "" if g.confidence == SURE else f": {g.reason.replace('; ', ', ')}"
    return f"{role}: '{g.column}' in {g.unit}{inv} ({g.confidence}{why})"


@dataclass(frozen=True)
class _Head:
    """What the guess read of a log's first :data:`GUESS_ROWS` rows, and what it made of them."""

    names: list[str]               #: every column of the file
    guesses: list[Guess]           #: :func:`~roadbank.io.guess.guess_channels`' guesses
    data: dict[str, np.ndarray]    #: the columns read, as stored
    stated: dict[str, str]         #: the units the file states (column -> unit)
    unread: dict[str, str]         #: the columns that could not be read as numbers (column -> why)


def _guess(p, fmt: str, names: list[str], default: ChannelMap, wanted: set[str] | None = None) -> _Head:
    """:func:`~roadbank.io.guess.guess_channels` on the columns of ``names`` named like a channel (and ``wanted``),
    their first :data:`GUESS_ROWS` rows."""
    cols = [c for c in names if not _truth(default, c)
            and (c in (wanted or ()) or any(name_match(role, c)[0] for role in NAMES))]
    data, times, stated, unread = readers.read_head(p, fmt, cols, GUESS_ROWS)
    guesses = guess_channels(names, data, times if fmt == "mdf4" else None, stated)
    return _Head(names, guesses, data, stated, unread)
