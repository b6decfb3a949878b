"""The assembler: raw channels of a source -> :class:`~roadbank.io.Log` chunks (SI, ISO 8855, one time base).

Every format (CSV, Parquet, MDF4, raw CAN, ROS, and the fixed layouts of KITTI raw drives and comma2k19
segments, whose sources bring their own channel map) comes here from its source
(:mod:`roadbank.io.sources`), whole or in chunks, and goes through the same steps in the same order:

1. **channel selection**: the roles the map names and the file has (:func:`select_roles`);
2. **time stamps**: the table clock (an MDF4 file's channels that all lie in one channel group share its stamps:
   read as a table on them, :func:`group_clock`), or each channel's own, repaired chunk by chunk
   (:class:`~roadbank.io.repair.ChunkRepair`); samples next to a repair are set to NaN. A table's rows
   of one instant that carry different channels (a long table) are merged first
   (:func:`~roadbank.io.repair.instants`): one instant, not a repeated stamp;
3. **SI and ISO 8855**: each channel's unit and sign convention (:meth:`ChannelMap.to_si_iso`; a time column
   whose type carries its own unit is in s whatever the map declares: :func:`own_time_unit`);
4. **plausibility** of each channel's values in its declared unit
   (:func:`~roadbank.io.channels.check_plausible`);
5. **resampling** onto one time base (:class:`~roadbank.io.resample.StreamResampler`; a channel sampled
   slower than ``max_gap_s`` is bridged (the speed) or warned about: :func:`rate_notes`); the span is the
   inputs' overlap, which the reference roll does not bound (:data:`REFERENCE_ROLES`: NaN where it has no
   sample, a warning where that leaves more than ``max_gap_s`` of the log's start or end);
6. **the log**: :class:`~roadbank.Signals`, reference roll, truth, GNSS position, the channels a
   source derives itself (``carried``: KITTI's leftward speed, a data set's position in degrees; into
   :attr:`Log.extra` as they are), the cross-channel consistency check
   (:func:`~roadbank.io.consistency.check_consistency`) and the repair counts.

A log read whole is one chunk and gives one :class:`Log`; streamed, the same steps give its
consecutive chunks, which put end to end equal the whole log. ``time_base = "auto"`` is decided on
the whole log (for a table read in chunks, by a first pass over it: :mod:`roadbank.io.survey`).

Which samples each check sees:

* unit plausibility of every channel: every chunk (a chunk whose values are impossible in the declared
  unit is refused, wherever it is); its warnings (a steering angle above one turn) from the first chunk;
* the time column's sample period and the cross-channel consistency: the start of the log, the first
  chunks until the check has enough samples to conclude (:data:`PERIOD_STAMPS` time stamps;
  :data:`~roadbank.io.consistency.MIN_SAMPLES` turning samples), then decided once. Both look for a
  wrong unit or sign, which holds for the whole log: a log that starts with a long straight is
  checked on the turns that follow it. A log read whole is one chunk: the whole log is checked.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..params import VehicleParams
from ..signals import Signals, concat_signals, road_wheel_angle
from . import units
from .channels import (DEFAULT_MAP_SOURCE, UNWRITTEN_MAPS, OPTIONAL, STEERING, ChannelMap, ChannelSpec, check_period,
                       check_plausible)
from .limits import Dropouts
from .consistency import (MIN_SAMPLES, SCALE_SPAN_S, Sums, check_balance, lateral_axis_error, log_verdict,
                          speed_scale_error, speed_scales, turning, usable)
from .errors import LogError, channel_error, channel_text
from .geodesy import ecef_to_latlon
from .repair import FLAGGED_ROLES, ChunkRepair, instants, interleaved_period
from .resample import BRIDGE_PERIODS, StreamResampler, clean_series
from .survey import auto_uses_clock
from .timebase import add_channel_counts, summed
from .types import GROUP_CLOCK, Log

#: GNSS fixes come at 1-20 Hz: a gap up to this long (s) is interpolated across
GNSS_MAX_GAP_S = 2.0
#: the roles that do not bound the log's time span (:class:`~roadbank.io.resample.StreamResampler`'s ``loose``):
#: the reference roll is no estimator's input, so a reference that covers less time than the inputs leaves the log
#: their span, the reference NaN where it has no sample (said by :meth:`_Logs.finish`)
REFERENCE_ROLES = ("reference_roll",)
#: time stamps the sample-period check of a table's time column gathers before it decides
PERIOD_STAMPS = 100
#: the roles whose own clock (MDF4, CAN, ROS) is checked for a sample period in another unit: noisy channels, sampled
#: steadily (a steering angle or a speed may be logged only when it changes)
CLOCKED_ROLES = ("lateral_acceleration", "yaw_rate")


def missing_column(p, role: str, column: str | None, names,
                   what: str = "column not found in the file", guessed: str = "") -> LogError:
    """The error for a required channel whose column is not in the file, with the way out: a
    channel map (``--channels map.toml``) that ``roadbank channels`` writes for the file's columns, or for an MDF4
    bus log (raw CAN frames) a map with its DBC. ``guessed``: what the guess of a map for the file's columns found and
    why it was not trusted (:mod:`roadbank.io.mapchoice`), said after the file's columns."""
    if any(str(n).startswith("CAN_DataFrame") for n in names):
        return channel_error(p, role, column, f"{what}: it is an MDF4 bus log (raw CAN frames, CAN_DataFrame), read "
                             "with a DBC: give a channel map with dbc = \"car.dbc\" and the signals of each channel "
                             "(--channels map.toml; docs/io.md, Raw CAN with a DBC)")
    return channel_error(p, role, column, f"{what} (it has: "
                         f"{', '.join(names) or 'nothing'}){'; ' + guessed if guessed else ''}; for a log with other "
                         "column names give a "
                         f"channel map with --channels map.toml (`roadbank channels {Path(p).name} -o map.toml` "
                         "writes one for these columns)")


def select_roles(p, cmap: ChannelMap, have: set, names) -> list[str]:
    """Roles to read: speed, lateral_acceleration, yaw_rate, [the steering role], [the optional roles of
    :data:`~roadbank.io.channels.OPTIONAL` whose column the file has], [reference_roll].

    The steering role is the road-wheel angle if its column exists, else the
    steering-wheel angle (none if the map has no steering channel: ROS maps; none if the file has
    neither column and the map's steering is optional: the default map, :func:`steering_note`).
    ``have`` are the columns present; ``names`` all the file's columns (for messages). LogError for a
    missing column.
    """
    steer_roles = [r for r in STEERING if r in cmap.channels]
    present: list[str | None] = [r for r in steer_roles if cmap.channels[r].column in have]
    if not steer_roles or (not present and cmap.steering_optional):   # no steering: delta_f NaN
        present = [None]
    roles = ["speed", "lateral_acceleration", "yaw_rate"]
    for role in roles:
        col = cmap.channels[role].column
        if col not in have:
            raise missing_column(p, role, col, names)
    if not present:
        cols = " or ".join(f"'{cmap.channels[r].column}'" for r in steer_roles)
        raise missing_column(p, "steering", None, names, f"missing: no column {cols} in the file")
    if present[0] is not None:
        roles.append(present[0])
    # optional: a map's optional channel that the file lacks is said by optional_notes
    roles += [r for r in OPTIONAL if r in cmap.channels and cmap.channels[r].column in have]
    if "reference_roll" in cmap.channels:
        roles.append("reference_roll")
        col = cmap.channels["reference_roll"].column
        if col not in have:
            raise channel_error(p, "reference_roll", col, f"column not found in the file "
                                f"(it has: {', '.join(names) or 'nothing'})")
    return roles


#: what a log read without an optional channel loses (the end of :func:`optional_notes`' warning)
OPTIONAL_LOSS = {"roll_rate": "a roll rate (the gyro-aided estimators give no valid sample)",
                 "longitudinal_acceleration": "a longitudinal acceleration (the gyro-aided estimators do not "
                                              "correct the roll rate for the grade)",
                 "pitch_rate": "a pitch rate (the gyro-aided estimators read the grade's pitch from the longitudinal "
                               "acceleration alone)"}


def optional_notes(p, cmap: ChannelMap, roles: list[str]) -> list[str]:
    """The warnings for a file read without an optional column its map names (the default map's ``p`` and ``ax``
    are not said: most logs have neither); ``[]`` otherwise."""
    if cmap.source == DEFAULT_MAP_SOURCE:
        return []
    return [channel_text(p, r, cmap.channels[r].column, f"column not found in the file, so the log is read without "
                         f"{OPTIONAL_LOSS[r]}") for r in OPTIONAL if r in cmap.channels and r not in roles]


#: what a steering angle that is NaN means for the estimators (the end of every warning that says so)
STEERING_NAN = ("the default estimator and the modified-model filters do not read it, the original-model ones, uio, "
                "dfc and kalman give no valid sample")


def steering_note(p, cmap: ChannelMap, roles: list[str]) -> list[str]:
    """The warning for a file read without the steering columns its (optional-steering) map names: the
    steering angle is NaN; ``[]`` otherwise."""
    steer = [r for r in STEERING if r in cmap.channels]
    if not steer or any(r in roles for r in steer):
        return []
    cols = " or ".join(f"'{cmap.channels[r].column}'" for r in steer)
    return [f"{Path(p).name}: channel 'steering': no column {cols}, so the steering angle is NaN ({STEERING_NAN})"]


def empty_steering(p, role: str, column: str | None, what: str = "no finite values") -> str:
    """The warning for a steering channel whose column is in the file but holds no value (``what``: no
    finite values, or no samples): the log is read as one without steering, its steering angle NaN, as
    :func:`steering_note` words it for a file without the column."""
    return channel_text(p, role, column, f"{what}, so the steering angle is NaN, as for a log without "
                        f"steering ({STEERING_NAN})")


def own_time_unit(p, cmap: ChannelMap, time_typed: dict[str, str]) -> tuple[ChannelMap, list[str]]:
    """The map to read a table with: its time channel in s when the column's type carries its own unit
    (``time_typed``: column -> type, a Parquet timestamp or duration, which the readers give in s), with the
    warning that the unit the map declares is ignored; ``cmap`` and ``[]`` otherwise."""
    spec = cmap.channels["time"]
    typed = time_typed.get(spec.column)
    if typed is None or units.factor("time", spec.unit) == 1.0:
        return cmap, []
    note = channel_text(p, "time", spec.column, f"the map's unit '{spec.unit}' is ignored: the column is {typed}, "
                        "which carries its own unit (read in s)")
    return replace(cmap, channels={**cmap.channels, "time": replace(spec, unit="s")}), [note]


def stated_units(p, cmap: ChannelMap, stated: dict[str, str]) -> tuple[ChannelMap, list[str]]:
    """The map to read a log with where the file states its columns' units (``stated``: column -> unit, a CSV's
    units row, an MDF4 channel's unit), with what it says of them. The default map's units are assumptions, so a
    unit the file states for one of its columns replaces the default's (said where they differ). A map the user
    wrote is kept, and a stated unit that differs from its declared one is warned about. A stated unit that is not
    one of the channel's kind (``-``, ``Nm`` under a speed) is said and the map's kept."""
    default = cmap.source == DEFAULT_MAP_SOURCE
    channels, notes = dict(cmap.channels), []
    for role, spec in cmap.channels.items():
        unit = stated.get(spec.column)
        if unit is None:
            continue
        try:
            same = units.factor(spec.kind, unit) == units.factor(spec.kind, spec.unit)
        except ValueError:
            notes.append(channel_text(p, role, spec.column, f"the file states '{unit}', not a unit of its "
                                      f"kind ({units.dimension_of_kind(spec.kind)}): read in '{spec.unit}', the "
                                      "map's"))
            continue
        if same:
            continue
        if default:
            channels[role] = replace(spec, unit=unit)
            notes.append(channel_text(p, role, spec.column, f"read in '{unit}', the unit the file states (the "
                                      f"default channel map assumes '{spec.unit}')"))
        else:
            notes.append(channel_text(p, role, spec.column, f"the file states '{unit}', the channel map "
                                      f"'{spec.unit}': read in '{spec.unit}', the map's (if the file is right, fix "
                                      "the map)"))
    return (replace(cmap, channels=channels) if channels != cmap.channels else cmap), notes


def steering_delta_f(cmap: ChannelMap, params: VehicleParams, roles: list[str], values: dict) -> np.ndarray:
    """``delta_f`` (rad): the road-wheel angle, or the steering-wheel angle over the steering ratio
    (the map's, else the car's; :func:`roadbank.signals.road_wheel_angle`), or NaN when the map has
    no steering channel (ROS robots; the modified-model estimators do not read it)."""
    if "road_wheel_angle" in roles:
        return values["road_wheel_angle"]
    if "steering_wheel_angle" in roles:
        car = params.replace(steering_ratio=cmap.steering_ratio) if cmap.steering_ratio else params
        return road_wheel_angle(values["steering_wheel_angle"], car)
    return np.full(len(values["speed"]), np.nan)


def gnss_roles(cmap: ChannelMap) -> list[str]:
    """The map's position channels: ``latitude``, ``longitude``; or ``ecef_x/y/z``; or none."""
    if {"latitude", "longitude"} <= set(cmap.channels):
        return ["latitude", "longitude"]
    if {"ecef_x", "ecef_y", "ecef_z"} <= set(cmap.channels):
        return ["ecef_x", "ecef_y", "ecef_z"]
    return []


def gnss_extra(p, cmap: ChannelMap, vals: dict, notes: list | None = None) -> dict:
    """``{"lat_deg", "lon_deg"}`` (deg) from position channels already on the time base (SI: rad or m). A value beyond
    the Earth's limits fails the read where the user's map names the channel; where a map the user did not write read
    it by its name (:data:`~roadbank.io.channels.UNWRITTEN_MAPS`), those samples are NaN and ``notes`` gets a warning
    (an estimate does not need the position, and a log's fill value, 999 on a lost fix, must not lose it)."""
    if "ecef_x" in vals:
        pos = np.stack([vals["ecef_x"], vals["ecef_y"], vals["ecef_z"]], axis=1)
        r = np.linalg.norm(pos, axis=1)
        r = r[np.isfinite(r)]
        if len(r) and not 6.30e6 < float(np.median(r)) < 6.42e6:
            spec = cmap.channels["ecef_x"]
            raise channel_error(p, "ecef_x", spec.column, f"median distance from the Earth's centre "
                                f"{float(np.median(r)):.4g} m after converting from '{spec.unit}': not an "
                                "ECEF position (WGS-84 radius ~6.37e6 m)")
        lat, lon = ecef_to_latlon(pos)
    else:
        lat, lon = vals["latitude"], vals["longitude"]
    out = {"lat_deg": np.degrees(lat), "lon_deg": np.degrees(lon)}
    for role, key, limit in (("latitude", "lat_deg", 90.0), ("longitude", "lon_deg", 180.0)):
        with np.errstate(invalid="ignore"):
            beyond = np.abs(out[key]) > limit
        if role not in cmap.channels or not beyond.any():
            continue
        spec = cmap.channels[role]
        what = f"|value| beyond {limit:g} deg after converting from '{spec.unit}'"
        if cmap.source not in UNWRITTEN_MAPS:
            raise channel_error(p, role, spec.column, what)
        out[key] = np.where(beyond, np.nan, out[key])
        if notes is not None:
            notes.append(channel_text(p, role, spec.column, f"{what} in {int(beyond.sum())} sample(s), read as no "
                                      "position there (NaN)"))
    return out


def same_rate(t: np.ndarray, vals: dict, roles) -> bool:
    """The ``time_base = "auto"`` rule of :func:`~roadbank.io.resample.common_time_base`: every role's
    valid samples come at the table clock's median period ``t`` (s), to 1 %."""
    if len(t) < 2:
        return False
    base = float(np.median(np.diff(t)))
    for r in roles:
        tc, _ = clean_series(t, vals[r])
        d = np.diff(tc)
        if not len(d) or abs(float(np.median(d)) - base) > 0.01 * base:
            return False
    return True


class _Logs:
    """Resampled output -> :class:`Log` s, given one behind: the last one waits for the repair
    counts and warnings that come after the last base time, and the log's length check."""

    def __init__(self, p, fmt, cmap, params, roles, gnss, truth_cols, metadata, carried=()):
        self.p, self.fmt, self.cmap, self.params = p, fmt, cmap, params
        self.roles, self.gnss, self.truth_cols, self.metadata = roles, gnss, truth_cols, metadata
        self.carried = list(carried)
        self.warnings: list[str] = []      # for the next log
        self.counts: dict = {}             # repair counts for the next log, channel -> kind -> int
        self.pending: Log | None = None
        self.n = 0                         # samples given so far
        self.span: list[float] = []        # the log's first and last base times (s)
        self.covered: list[float] = []     # ... and those where the reference roll is finite (s)
        self.balance = _Balance(p, {r: cmap.channels[r].column for r in [*roles[:3], *({"roll_rate"} & set(roles))]})

    def add(self, out, counts: dict) -> Iterator[Log]:
        """The log of one :meth:`StreamResampler.emit` output (nothing for None), with the repair
        ``counts`` found since the last log (channel -> kind -> int)."""
        self.counts = add_channel_counts(self.counts, counts)
        if out is None or not len(out["t"]):
            return
        p, cmap = self.p, self.cmap
        # a steering role left out at the log's end (no finite value) is not in the output
        delta = steering_delta_f(cmap, self.params, [r for r in self.roles if r in out], out)
        try:
            sig = Signals(out["t"], out["speed"], out["lateral_acceleration"], out["yaw_rate"], delta,
                          **{c: out.get(r) for r, c in OPTIONAL.items()},
                          fixed=frozenset(OPTIONAL.values()) if cmap.fixed_layout else frozenset(),
                          unbiased=cmap.unbiased)
        except ValueError as exc:
            raise LogError(f"{p}: {exc}") from None
        pos = {r: out[r] for r in self.gnss}
        extra = gnss_extra(p, cmap, pos, self.warnings) if pos else {}
        extra.update({c: out[c] for c in self.carried})
        log = Log(signals=sig, reference_roll=out.get("reference_roll"), source=p, format=self.fmt,
                  metadata=dict(self.metadata), truth={c: out[c] for c in self.truth_cols},
                  warnings=self.warnings, channel_map=cmap, extra=extra, time_repairs=summed(self.counts),
                  time_repairs_by_channel=self.counts)
        self.warnings, self.counts = [], {}
        log.warnings += self.balance.add(sig)
        self.n += len(sig)
        self.span = [self.span[0] if self.span else float(sig.t[0]), float(sig.t[-1])]
        if log.reference_roll is not None:
            ok = np.isfinite(log.reference_roll)
            if ok.any():
                tk = sig.t[ok]
                self.covered = [self.covered[0] if self.covered else float(tk[0]), float(tk[-1])]
        if self.pending is not None:
            yield self.pending
        self.pending = log

    def finish(self, counts: dict) -> Iterator[Log]:
        """The last log, with ``counts`` (channel -> kind -> int) and the warnings left; LogError if the log is too
        short."""
        if self.n < 2:
            raise LogError(f"{self.p}: fewer than 2 samples on the common time base")
        assert self.pending is not None        # two samples or more were assembled
        by_channel = add_channel_counts(self.pending.time_repairs_by_channel, add_channel_counts(self.counts, counts))
        self.pending.time_repairs, self.pending.time_repairs_by_channel = summed(by_channel), by_channel
        self.pending.warnings += self.warnings + self.balance.finish() + self._coverage()
        yield self.pending

    def _coverage(self) -> list[str]:
        """The warning for a reference roll that leaves more than ``max_gap_s`` of the log's start or end without a
        sample (NaN there: the log keeps its inputs' span, :data:`REFERENCE_ROLES`); ``[]`` otherwise."""
        role = "reference_roll"
        if role not in self.roles or not self.span:
            return []
        col = self.cmap.channels[role].column
        t0, t1 = self.span
        if not self.covered:
            return [channel_text(self.p, role, col, f"no sample within the log's span ({t0:.3f} to {t1:.3f} s): the "
                                 "reference roll is NaN throughout (nothing to score the estimate against)")]
        c0, c1 = self.covered
        if c0 - t0 <= self.cmap.max_gap_s and t1 - c1 <= self.cmap.max_gap_s:
            return []
        ends = ((c0 - t0, "before"), (t1 - c1, "after"))
        where = " and ".join(f"the {d:.2f} s {side} it" for d, side in ends if d > 0)
        return [channel_text(self.p, role, col, f"covers {c0:.3f} to {c1:.3f} s of the log's {t0:.3f} to {t1:.3f} s: "
                             f"the reference roll is NaN for {where} (the log keeps the span of its inputs, and an "
                             "estimate is not scored where it has no reference)")]


class _Balance:
    """The cross-channel consistency check on the start of a log: the samples it reads
    (:func:`~roadbank.io.consistency.usable`), gathered chunk by chunk until
    :data:`~roadbank.io.consistency.MIN_SAMPLES` of them are turning, then decided once (a log read
    whole: on the whole log). Holds those samples only, and the sums of the gentle turns' slope for a log that
    never gets there (:meth:`finish`)."""

    def __init__(self, p, columns: dict):
        self.p, self.columns = p, columns
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.turning = 0
        self.sums = Sums()                  # consistency.Sums so far
        self.decided = False
        self.span: list[Signals] | None = []    # the first SCALE_SPAN_S, until ay's axis and the speed's scale are read

    def add(self, sig: Signals) -> list[str]:
        """The check's warnings once it is decided with ``sig`` (SI), [] before and after;
        LogError as :func:`~roadbank.io.consistency.check_consistency`."""
        vx, ay, r = (np.asarray(a, dtype=np.float64) for a in (sig.vx, sig.ay, sig.r))
        self.sums = self.sums + Sums.of(vx, ay, r, sig.p)
        if self.span is not None:
            self.span.append(sig)
            if sig.t[-1] > self.span[0].t[0] + SCALE_SPAN_S:
                self._scale()
        if self.decided:
            return []
        keep = usable(vx, ay, r)
        self.parts.append((vx[keep], ay[keep], r[keep]))
        self.turning += int(turning(vx[keep], ay[keep], r[keep]).sum())
        if self.turning < MIN_SAMPLES:
            return []
        self.decided = True
        vx, ay, r = (np.concatenate(a) for a in zip(*self.parts))
        self.parts = []
        return check_balance(vx, ay, r, self.p, self.columns)

    def finish(self) -> list[str]:
        """At the end of the log: the checks of the whole log (:func:`~roadbank.io.consistency.log_verdict`: a dead
        channel, a unit that scales ``vx r``, and where it never had :data:`~roadbank.io.consistency.MIN_SAMPLES`
        turning samples, the slope warnings of its gentle turns); LogError for a refusal."""
        self._scale()
        return log_verdict(self.sums, self.decided, self.p, self.columns)

    def _scale(self) -> None:
        """The speed's scale and ay's axis on the log's first :data:`~roadbank.io.consistency.SCALE_SPAN_S` (once;
        LogError for an ay that reads the forward axis, :func:`~roadbank.io.consistency.lateral_axis_error`, or a speed
        read in another unit, :func:`~roadbank.io.consistency.speed_scale_error`)."""
        if self.span:
            s = concat_signals(self.span)
            lateral_axis_error(s.t, s.vx, s.ay, s.r, self.p, self.columns)
            speed_scale_error(speed_scales(s.t, s.vx, s.ay, s.r, s.p, s.ax), self.p, self.columns)
        self.span = None


class _Period:
    """The sample-period check of a table's time column (or of a channel's own clock: ``role``, ``column`` and
    ``unit`` those of the stamps, ``what`` opening the message) on the start of the log: its stamps gathered chunk by
    chunk until there are :data:`PERIOD_STAMPS` (a log read whole: all of them), then
    :func:`~roadbank.io.channels.check_period` once."""

    def __init__(self, p, role: str, column: str, unit: str, what: str = ""):
        self.p, self.role, self.column, self.unit, self.what = p, role, column, unit, what
        self.parts: list[np.ndarray] = []
        self.n = 0
        self.decided = False

    def add(self, t: np.ndarray, last: bool) -> None:
        """Stamps ``t`` (s) of the next chunk (``last``: the log's final one); LogError for an
        implausible period."""
        if self.decided:
            return
        self.parts.append(t)
        self.n += len(t)
        if self.n >= PERIOD_STAMPS or last:
            self.decided = True
            check_period(self.p, self.role, self.column, self.unit, np.concatenate(self.parts), self.what)
            self.parts = []


def _time_base(p, cmap: ChannelMap, roles, table: bool = True) -> str:
    """The map's time base; LogError for a role name the log does not read, or for ``"clock"`` on a log
    without a table clock."""
    tb = cmap.time_base
    if tb == "clock" and not table:
        raise LogError(f"{p}: resample.time_base 'clock' needs a table with a time column (CSV, Parquet); "
                       "here every channel has its own clock")
    if tb not in ("auto", "uniform", "clock") and tb not in roles:
        raise LogError(f"{p}: resample.time_base '{tb}' is not one of the log's channels ({', '.join(roles)})")
    return tb


def assemble(src, cmap: ChannelMap, params: VehicleParams, fmt: str) -> Iterator[Log]:
    """The log of source ``src`` in chunks (see the module doc).

    Parameters
    ----------
    src : source
        A table or channel source of :mod:`roadbank.io.sources`.
    cmap : ChannelMap
    params : VehicleParams
        Supplies the steering ratio when the map gives a steering-wheel angle without one.
    fmt : str
        Format name, for :attr:`Log.format`.

    Yields
    ------
    Log
        Consecutive chunks of the log: ``signals`` (SI, ISO 8855), ``reference_roll`` (rad),
        ``truth``, ``extra`` (``lat_deg`` / ``lon_deg``, deg) on the chunk's base times.

    Raises
    ------
    LogError
        Naming the file, the channel and the problem, when the bad part is reached.
    """
    p = src.path
    roles = select_roles(p, cmap, set(src.names), src.names)
    src.warnings += steering_note(p, cmap, roles) + optional_notes(p, cmap, roles)
    gnss = gnss_roles(cmap)
    for r in gnss:
        if cmap.channels[r].column not in src.names:
            raise channel_error(p, r, cmap.channels[r].column, f"column not found in the file "
                                f"(it has: {', '.join(src.names) or 'nothing'})")
    if src.shared_clock:
        yield from _tables(src, cmap, params, fmt, roles, gnss)
    elif group_clock(src, cmap, roles, gnss):
        clock = replace(cmap, channels={**cmap.channels, "time": ChannelSpec("time", GROUP_CLOCK, "s")})
        yield from _tables(src, clock, params, fmt, roles, gnss, grouped=True)
    else:
        yield from _channels(src, cmap, params, fmt, roles, gnss)


def group_clock(src, cmap: ChannelMap, roles, gnss) -> bool:
    """Whether a channel source's channels to read (``roles`` and ``gnss``) share one time array -- an MDF4 file's
    channels of one channel group, a logger's raster -- and are read as a table on it (the source then gives them
    so: :meth:`~roadbank.io.sources.WholeSource.one_clock`): their stamps as stored (repaired as a table's clock
    is) and, where ``time_base = "auto"`` finds every channel at the clock's rate, their values as stored, as a CSV
    or Parquet table's are. Where the map asks for another time base (``"uniform"``, a role), or the channels lie
    in several groups, each keeps its own clock and is interpolated (:func:`_channels`)."""
    one_clock = getattr(src, "one_clock", None)
    if one_clock is None or cmap.time_base not in ("auto", "clock"):
        return False
    return bool(one_clock({cmap.channels[r].column: r for r in roles + gnss}))


def _tables(src, cmap, params, fmt, roles, gnss, grouped: bool = False) -> Iterator[Log]:
    """A table: every column on the table's time column (``grouped``: an MDF4 channel group's stamps,
    :func:`group_clock`; no truth columns, and the clock's period checked as a channel's own stamps are)."""
    p, names = src.path, src.names
    if "time" not in cmap.channels:
        raise LogError(f"{cmap.source}: channel map has no 'time' channel (required for {fmt})")
    cmap, note = own_time_unit(p, cmap, src.time_typed)
    cmap, said = stated_units(p, cmap, src.units)
    note += said
    tspec = cmap.channels["time"]
    if tspec.column not in names and not grouped:
        raise missing_column(p, "time", tspec.column, names)
    wanted = {spec.column: role for role, spec in cmap.channels.items()}
    prefix = None if grouped else cmap.truth_prefix
    truth_cols = [c for c in names if prefix and c.startswith(prefix) and c not in wanted]
    tb = _time_base(p, cmap, roles)
    if tb == "auto" and not src.whole:    # decided on the whole log, as when it is read in one chunk
        used = {cmap.channels[r].column: r for r in ["time"] + roles}     # (a pass reads these only)
        tb = "clock" if auto_uses_clock(lambda: ((t, vals) for _, t, _, vals, _, _ in
                                                 _table_rows(src, cmap, roles, used, None)), roles,
                                        optional=STEERING) else "uniform"
    carried = dict(src.carried)
    logs = _Logs(p, fmt, cmap, params, roles, gnss, truth_cols, src.metadata, carried)
    logs.warnings += src.warnings + note
    finite = dict.fromkeys(roles, False)
    # (a channel group's master: named by the channel it clocks, as each channel's own stamps are in _channels)
    period = (_Period(p, CLOCKED_ROLES[0], cmap.channels[CLOCKED_ROLES[0]].column, "s", "its time stamps: ")
              if grouped else _Period(p, "time", tspec.column, tspec.unit))
    drops = Dropouts(p, {r: cmap.channels[r].column for r in roles})
    rs = None
    empty: list[str] = []       # a steering role without a finite value in the whole log
    for last, t, cols, vals, w, fix in _table_rows(src, cmap, roles, wanted, prefix):
        logs.warnings += w
        first = rs is None and len(t) > 0
        period.add(t, last)
        for r in roles:
            spec = cmap.channels[r]
            w = check_plausible(p, r, spec.column, spec.unit, t, vals[r])
            if first:
                logs.warnings += w
            vals[r] = drops.apply(r, t, vals[r])
            finite[r] = finite[r] or bool(np.isfinite(vals[r]).any())
            if last and not finite[r]:
                if r not in STEERING or r == tb:
                    raise channel_error(p, r, spec.column, "no finite values")
                logs.warnings.append(empty_steering(p, r, spec.column))
                empty.append(r)     # read as a log without it
        if first:
            kept = [r for r in roles if r not in empty]
            base = ("clock" if same_rate(t, vals, kept) else "uniform") if tb == "auto" else tb
            # carried channels: on the clock as they are; on any other base, interpolated with their gap
            aux = {**dict.fromkeys(gnss, GNSS_MAX_GAP_S), **({} if base == "clock" else carried)}
            rs = StreamResampler(roles, aux, base, cmap.rate_hz, cmap.max_gap_s,
                                 raw=truth_cols + (list(carried) if base == "clock" else []), loose=REFERENCE_ROLES)
        if rs is None:
            if last:
                raise LogError(f"{p}: fewer than 2 samples on the common time base")
            continue
        for r in empty:
            if r in rs.roles:
                rs.drop(r)
        rs.add_clock(t)
        for r in roles:
            if r not in empty:
                rs.add(r, t, vals[r])
        for r in gnss:
            rs.add(r, t, cmap.to_si_iso(r, cols[cmap.channels[r].column]))
        for c in truth_cols + list(carried):
            rs.add(c, t, cols[c])
        if last:
            for k in rs.done:
                rs.finish(k)
        out = _emit(p, rs)
        logs.warnings += resampler_notes(p, rs, {r: cmap.channels[r].column for r in roles}, cmap.max_gap_s)
        yield from logs.add(out, {"time": fix.take_counts()})
    logs.warnings += drops.warnings()
    yield from logs.finish({})


def _table_rows(src, cmap, roles, wanted, prefix):
    """The table's chunks with the clock repaired: ``(last, t, columns, role values, warnings, repair)``
    per chunk; ``t`` (s) and the role values (SI, ISO 8855, NaN where flagged by the repair) row for
    row, the columns as stored.

    Rows that share a stamp and carry different channels (a long table) are first made one row
    (:func:`~roadbank.io.repair.instants`), so each channel keeps its samples; the repair then sees a
    stamp repeated for the same channel only. Gaps are counted against the fastest channel's period where
    the rows interleave channels at different stamps (:func:`~roadbank.io.repair.interleaved_period`)."""
    tspec = cmap.channels["time"]
    fix = ChunkRepair(src.path, tspec.column, "time", src.row_label)
    flag_cols = [cmap.channels[r].column for r in FLAGGED_ROLES if r in cmap.channels]
    role_cols = [cmap.channels[r].column for r in roles]
    for last, t, data, rownums in instants(src.chunks(wanted, prefix), tspec.column,
                                           lambda a: cmap.to_si_iso("time", a)):
        t, cols, flagged, w = fix.feed(t, data, rownums, last, interleaved_period(t, data, role_cols))
        for c in flag_cols:          # every column follows the repaired clock; flagged rows become NaN
            if c in cols:
                cols[c][flagged] = np.nan
        vals = {r: cmap.to_si_iso(r, cols[cmap.channels[r].column]) for r in roles}
        yield last, t, cols, vals, w, fix


def _channels(src, cmap, params, fmt, roles, gnss) -> Iterator[Log]:
    """Channels that each carry their own clock (MDF4, raw CAN, ROS)."""
    p = src.path
    cmap, stated = stated_units(p, cmap, src.units)
    tb = _time_base(p, cmap, roles, table=False)
    carried = dict(src.carried)
    rs = StreamResampler(roles, {**dict.fromkeys(gnss, GNSS_MAX_GAP_S), **carried},
                         "uniform" if tb == "auto" else tb, cmap.rate_hz, cmap.max_gap_s, loose=REFERENCE_ROLES)
    read = roles + gnss + list(carried)
    col = {r: cmap.channels[r].column for r in roles + gnss} | {c: c for c in carried}
    fixes = {r: ChunkRepair(p, col[r], r, "sample", hold_last=True) for r in read}
    rows = dict.fromkeys(read, 0)
    finite = dict.fromkeys(roles, False)
    checked = dict.fromkeys(roles, False)
    logs = _Logs(p, fmt, cmap, params, roles, gnss, [], src.metadata, carried)
    logs.warnings += src.warnings + stated
    drops = Dropouts(p, {r: col[r] for r in roles})
    # the clocks of the channels that never pause (noise): a master in ms or ns is named before any resampling
    periods = {r: _Period(p, r, col[r], "s", "its time stamps: ") for r in CLOCKED_ROLES if r in roles}

    def counts() -> dict:
        return {r: fixes[r].take_counts() for r in roles}

    for chunk in src.chunks({col[r]: r for r in read}):
        for r in read:
            c, fix = col[r], fixes[r]
            ends = c in chunk.done
            if c in chunk.data:
                n = len(chunk.data[c])
                t, got, flagged, w = fix.feed(chunk.times[c], {"v": chunk.data[c]},
                                           np.arange(rows[r], rows[r] + n), ends)
                rows[r] += n
            elif ends and fix.holding:
                t, got, flagged, w = fix.feed(np.zeros(0), {"v": np.zeros(0)}, [], True)
            else:
                t = None
            if t is not None:
                v = got["v"] if r in carried else cmap.to_si_iso(r, got["v"])
                if r in roles:               # (a position or carried channel: repaired, neither flagged nor checked)
                    if r in periods:
                        periods[r].add(t, ends)
                    logs.warnings += w
                    if r in FLAGGED_ROLES:
                        v[flagged] = np.nan
                    spec = cmap.channels[r]
                    w = check_plausible(p, r, spec.column, spec.unit, t, v)
                    if len(t) and not checked[r]:
                        checked[r] = True
                        logs.warnings += w
                    v = drops.apply(r, t, v)
                    finite[r] = finite[r] or bool(np.isfinite(v).any())
                rs.add(r, t, v)
            if ends and r in roles and not finite[r]:
                what = "no samples" if not rows[r] else "no finite values"
                if r not in STEERING or r == tb:
                    raise channel_error(p, r, c, what)
                logs.warnings.append(empty_steering(p, r, c, what))
                rs.drop(r)          # read as a log without it
            elif ends:
                rs.finish(r)
        out = _emit(p, rs)
        logs.warnings += resampler_notes(p, rs, col, cmap.max_gap_s)
        yield from logs.add(out, counts())
    logs.warnings += drops.warnings()
    yield from logs.finish(counts())


def resampler_notes(p, rs: StreamResampler, columns: dict, max_gap_s: float) -> list[str]:
    """The resampler's warnings since the last call: :func:`rate_notes` and the pauses its grid left out."""
    out = rate_notes(p, rs.take_notes(), columns, max_gap_s)
    for a, b in rs.take_pauses():
        out.append(f"{p}: no channel has a sample for {b - a:.6g} s (from t = {a:.6g} to {b:.6g} s: a pause of the "
                   f"logger or a wrong time stamp): the resampled log leaves that time out (no rows) and the "
                   f"estimators start again after it")
    return out


def rate_notes(p, notes, columns: dict, max_gap_s: float) -> list[str]:
    """The warnings for channels sampled slower than the resampler's ``max_gap_s`` (s): ``notes`` are
    :attr:`StreamResampler.notes` (role, sample period, bridged gap or None; s), ``columns`` role -> column."""
    out = []
    for role, period, bridged in notes:
        head = (f"sampled every {period:.3g} s (the median step of its first samples), longer than the gap "
                f"the resampler interpolates across (resample.max_gap_s = {max_gap_s:g} s)")
        if bridged is not None:
            text = (f"{head}: interpolated across its own steps up to {bridged:.3g} s ({BRIDGE_PERIODS:g} of its "
                    "sample periods: a speed changes little in that time), a longer step stays a gap (NaN)")
        else:
            text = (f"{head}: the base times between its samples are NaN, not estimated -- to interpolate across "
                    f"them, set max_gap_s above {period:.3g} s under [resample] in a channel map (--channels "
                    f"map.toml, `roadbank channels {Path(p).name} -o map.toml` writes one)")
        out.append(channel_text(p, role, columns.get(role), text))
    return out


def _emit(p, rs: StreamResampler):
    try:
        return rs.emit()
    except LogError as exc:
        raise LogError(f"{p}: {exc}") from None


def concat_logs(chunks: list[Log]) -> Log:
    """Consecutive chunks of one log as one :class:`Log` (the first chunk's metadata and map)."""
    if len(chunks) == 1:
        return chunks[0]
    first = chunks[0]

    def joined(get) -> dict:
        return {k: np.concatenate([get(c)[k] for c in chunks]) for k in get(first)}

    repairs: dict = {}
    for c in chunks:
        repairs = add_channel_counts(repairs, c.time_repairs_by_channel)
    roll = None if first.reference_roll is None else np.concatenate([c.reference_roll for c in chunks])
    return Log(signals=concat_signals([c.signals for c in chunks]), reference_roll=roll, source=first.source,
               format=first.format, metadata=first.metadata, truth=joined(lambda c: c.truth),
               warnings=[w for c in chunks for w in c.warnings], channel_map=first.channel_map,
               extra=joined(lambda c: c.extra), time_repairs=summed(repairs), time_repairs_by_channel=repairs)


def read_whole(src, cmap: ChannelMap, params: VehicleParams, fmt: str) -> Log:
    """The log of source ``src`` in one :class:`Log` (:func:`assemble`, then :func:`concat_logs`); the
    source is closed after."""
    try:
        return concat_logs(list(assemble(src, cmap, params, fmt)))
    finally:
        src.close()
