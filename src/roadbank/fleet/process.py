"""One log, streamed: read in chunks, estimate with continued state, write incrementally, summarise."""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from ..constants import G as G_UNIT
from ..defaults import ESTIMATOR as DEFAULT
from ..estimators import OFFLINE, with_online_offsets
from ..io import LogError
from ..io.stream import CHUNK_ROWS, ReadAhead, stream_log
from ..io.timebase import add_channel_counts, add_counts
from ..io.writers import TableWriter, estimate_table, write_error
from ..signals import Estimate
from ..vehicle import (DESIGN_MAX_S, car_for_log, for_conditions, has_design_span, load_vehicle, log_conditions,
                       undescribed_params)
from ..vehicle.factory import is_described
from ..vehicle.conditions import (GYRO_MODELS, QUIET_MODELS, ROLL_SLOPE_RANGE, RoadCheck, design_ay_floor,
                                  handed_over_warnings, hands_over, keeps_cars_model, louder_warnings,
                                  models_car, roll_rate_usable)

#: columns of the summary table, in order (see LogSummary)
SUMMARY_COLUMNS = ("log", "status", "error", "output", "estimator", "samples", "duration_s", "valid_share",
                   "bank_mean_deg", "bank_min_deg", "bank_max_deg", "chunks", "seconds", "warnings",
                   "time_repairs", "design")


@dataclass
class LogSummary:
    """What :func:`estimate_log` did with one log (one row of the fleet summary table).

    Attributes
    ----------
    log : str
        The log's path.
    status : str
        "ok" or "error".
    error : str
        The reason (file, channel, problem) when status is "error".
    output : str
        The table written (empty on error: a partial file is removed).
    estimator : str
        The estimator the statistics below are of (the first one asked for).
    samples : int
        Samples on the estimator grid.
    duration_s : float
        Last minus first time stamp (s).
    valid_share : float
        Share of samples the estimator flagged valid (0..1).
    bank_mean_deg, bank_min_deg, bank_max_deg : float
        Road bank ``phi_b`` over the valid samples (deg; NaN if none).
    chunks : int
        Chunks the log was streamed in.
    seconds : float
        Wall time to read, estimate and write (s).
    warnings : str
        Reader warnings, "; "-separated.
    time_repairs : dict kind -> int
        What the time-stamp repair did to the log (:attr:`roadbank.io.Log.time_repairs`, summed
        over its chunks); in the summary table as ``kind=n`` pairs, "; "-separated (the non-zero ones).
    time_repairs_by_channel : dict channel -> dict kind -> int
        The same channel by channel (:attr:`roadbank.io.Log.time_repairs_by_channel`, summed over the chunks).
    estimators : dict name -> dict
        ``valid_share``, ``bank_mean_deg``, ``bank_min_deg``, ``bank_max_deg`` of every estimator
        asked for (the columns above are those of the first one).
    design : dict
        What the estimators were designed for (:func:`roadbank.vehicle.design_record`: the car, whether
        the log is quiet, its ``ay`` noise and floor); in the summary table as ``key=value`` pairs
        (:func:`design_text`). Empty on error.
    plot_error : str
        Why the log's plot could not be written (its table was; not a column: the warning says it).
    """

    log: str
    status: str = "ok"
    error: str = ""
    output: str = ""
    estimator: str = ""
    samples: int = 0
    duration_s: float = math.nan
    valid_share: float = math.nan
    bank_mean_deg: float = math.nan
    bank_min_deg: float = math.nan
    bank_max_deg: float = math.nan
    chunks: int = 0
    seconds: float = 0.0
    warnings: str = ""
    time_repairs: dict = field(default_factory=dict)
    time_repairs_by_channel: dict = field(default_factory=dict)
    estimators: dict = field(default_factory=dict)
    design: dict = field(default_factory=dict)
    kept: object = field(default=None, repr=False, compare=False)
    plot_error: str = field(default="", compare=False)

    def row(self) -> dict:
        """The summary-table row (every column of :data:`SUMMARY_COLUMNS`)."""
        d = asdict(self)
        d.pop("kept")
        d["time_repairs"] = "; ".join(f"{k}={v}" for k, v in self.time_repairs.items() if v)
        d["design"] = design_text(self.design)
        return {k: d[k] for k in SUMMARY_COLUMNS}


def design_text(design: dict) -> str:
    """:attr:`LogSummary.design` as ``key=value`` pairs, "; "-separated ('' when empty)."""
    return "; ".join(f"{k}={v}" for k, v in design.items())


def _times(ratio: float) -> str:
    """The log's ``ay`` noise against the data sheet's, in words: ``"3.5 x the data sheet's noise density"`` (a ratio
    of power densities, (m/s^2)^2/Hz, as :data:`~roadbank.vehicle.QUIET_RATIO` reads it: the standard deviations
    beside it are in the ratio's square root); a data sheet that gives no noise (a vehicle file's ``ay_noise = 0``)
    said so rather than as infinitely many times."""
    return (f"{ratio:.2g} x the data sheet's noise density" if math.isfinite(ratio)
            else "the data sheet gives no ay noise")


def trim_words(design: dict) -> str:
    """What a design record (:func:`roadbank.vehicle.car_for_log`) says of the described car's rear cornering
    stiffness, as a clause after the car (', ...'; '' where it says nothing): the scale it was trimmed to, or that it
    was measured."""
    if "rear_trim" in design:
        return f", its rear cornering stiffness x {design['rear_trim']:g} (trimmed to the log)"
    return ", its rear cornering stiffness as measured" if design.get("rear_measured") else ""


def design_words(design: dict, estimator: str) -> str:
    """:attr:`LogSummary.design` in words, for the estimator ``estimator`` ('' when empty): the car, the
    ``ay`` noise and floor (m/s^2; what was not measured is said so, and what the design took instead), the channels
    written faster than their sensor (their noise read at the source's rate; a log that holds its sensors' frames read
    at their rate), and for an estimator that changes on a quiet log what it is."""
    if not design:
        return ""
    noise, floor, ratio = design["ay_noise"], design["ay_floor"], design["ay_floor_ratio"]
    if not math.isfinite(noise) and not math.isfinite(floor):
        heard = ("ay noise not measured (too little unbroken driving at 5 m/s or more in the log's first minute: "
                 "stops, dropouts and gaps break it): designed for the data sheet's noise, not known to be quiet")
    elif not math.isfinite(floor):
        heard = (f"ay noise {noise:.2g} m/s^2 ({_times(ratio)}; its floor not measured: no stretch of "
                 f"driving long enough): {'quiet' if design['quiet'] else 'loud'}")
    else:
        heard = (f"ay noise {noise:.2g} m/s^2, floor {floor:.2g} ({_times(ratio)}): "
                 f"{'quiet' if design['quiet'] else 'loud'}")
    words = f"{design['car']} ({design['car_from']}{trim_words(design)}); {heard}"
    slope, ax = design.get("roll_rate"), design.get("ax")
    gyro = roll_rate_usable(slope)
    if estimator in QUIET_MODELS:
        pitch = " and pitch rate" if roll_rate_usable(design.get("pitch_rate")) else ""
        grade = f"; corrected for the grade by its ax{pitch}" if roll_rate_usable(ax) else ""
        free = ", free of offset (an INS's)" if design.get("roll_rate_unbiased") else ""
        loud = f"{GYRO_MODELS[estimator]} (the log has a roll rate{free}{grade})" if gyro else "the low-pass blend"
        quiet = keeps_cars_model(design["quiet"], slope, bool(design.get("roll_rate_unbiased")))
        model = quiet and models_car(estimator, is_described(design))
        unread = " (its roll rate not read: a quiet log keeps the car's model)" if model and gyro else ""
        until = (" until its roads turn loud (then the design of its first loud minute)"
                 if model and hands_over(slope) and estimator not in OFFLINE else "")
        nobody = (" (a quiet log, but the car's model is kept only for a car described: a vehicle file, --vehicle; "
                  "roadbank identify writes one from logs with a steering angle)")
        words += f", so {estimator} is {QUIET_MODELS[estimator] + unread + until if model else loud}"
        words += nobody if quiet and not model else ""
    if slope is not None and not gyro:
        off = _off(slope, ROLL_RATE_MISTAKES, ROLL_SUSPECTS)
        words += f"; its roll rate does not follow the roll in its ay ({off}), so it is not used"
    if gyro and ax is not None and not roll_rate_usable(ax):
        words += (f"; its ax does not follow its speed ({_off(ax, AX_MISTAKES)}), so the roll rate is not corrected "
                  "for the grade")
    q = design.get("pitch_rate")
    if gyro and roll_rate_usable(ax) and q is not None and not roll_rate_usable(q):
        words += (f"; its pitch rate does not follow the pitch in its ax ({_off(q, RATE_MISTAKES)}), so the grade's "
                  "pitch comes from its ax alone")
    if design.get("held"):
        words += (f"; written by holding its sensors' frames, read at their rate, {design['held']:.3g} Hz (the rows "
                  "that repeat a frame left out, their outputs the frame's)")
    if design.get("source"):
        words += (f"; written faster than their sensor, noise (and the gate's yaw rate, where r is so written) read at "
                  f"the sensor's rate: {design['source']}")
    return words


#: what a roll or pitch rate's check slope (:func:`~roadbank.vehicle.conditions.roll_rate_slope`: 1 for a right
#: channel) reads for a usual mistake: (the slope it gives, the mistake)
RATE_MISTAKES = ((math.pi / 180, "deg/s declared as rad/s"), (180 / math.pi, "rad/s declared as deg/s"),
                 (-1.0, "the opposite sign, which invert = true in a channel map turns"))
#: ... a roll rate's: it reads the same in ISO and FRD, so an opposite sign may be ay's and the yaw rate's instead
ROLL_RATE_MISTAKES = RATE_MISTAKES[:2] + (
    (-1.0, "the opposite sign: either the roll rate's (invert = true on it in a channel map) or ay's and the yaw "
           "rate's (FRD declared as ISO, an upside-down sensor: convention = \"FRD\"), which mirrors the bank; a roll "
           "rate reads the same in both conventions, so check ay's sign in a left turn (a pitch rate and ax would "
           "tell: with them, FRD is refused)"),)
#: what a roll rate's check names where no usual mistake fits: either channel may be the wrong one
ROLL_SUSPECTS = ("another axis, sign or unit of the roll rate, or an ay from another axis (a sensor mounted turned "
                 "in the car reads its ax there)?")
#: ... and ``ax``'s (:func:`~roadbank.vehicle.conditions.ax_slope`)
AX_MISTAKES = ((G_UNIT, "g declared as m/s^2"), (1 / G_UNIT, "m/s^2 declared as g"),
               (-1.0, "the opposite sign, which invert = true in a channel map turns"))


def _off(slope: float, mistakes, suspects: str = "another axis, sign or unit?") -> str:
    """Words for a check slope outside :data:`~roadbank.vehicle.conditions.ROLL_SLOPE_RANGE`: the slope, and the
    mistake of ``mistakes`` whose slope it is within that range's factors (0.5-2) of, else the usual ``suspects``."""
    lo, hi = ROLL_SLOPE_RANGE
    named = [what for k, what in mistakes if lo <= slope / k <= hi]
    return f"slope {slope:.2g}, not {lo:g}-{hi:g}: " + (f"it reads like {named[0]}" if named else suspects)


class _BankStats:
    """Running count / valid count / sum / min / max of phi_b over valid samples."""

    def __init__(self):
        self.n = self.nvalid = self.nsettled = 0
        self.sum = 0.0
        self.min, self.max = math.inf, -math.inf
        self.t0 = self.t1 = math.nan

    def add(self, est) -> None:
        v = est.phi_b[est.valid]
        self.n += len(est.t)
        if len(est.t):
            self.t0 = est.t[0] if math.isnan(self.t0) else self.t0
            self.t1 = est.t[-1]
        self.nsettled += int(np.count_nonzero(est.settled))
        if len(v):
            self.nvalid += len(v)
            self.sum += float(v.sum())
            self.min = min(self.min, float(v.min()))
            self.max = max(self.max, float(v.max()))

    def fill(self, s: LogSummary) -> None:
        s.samples = self.n
        s.duration_s = float(self.t1 - self.t0) if self.n else math.nan
        for k, v in self.stats().items():
            setattr(s, k, v)

    def stats(self) -> dict:
        """``valid_share`` and ``bank_mean_deg``, ``bank_min_deg``, ``bank_max_deg`` (NaN without a valid sample)."""
        out = {"valid_share": self.nvalid / self.n if self.n else math.nan,
               "bank_mean_deg": math.nan, "bank_min_deg": math.nan, "bank_max_deg": math.nan}
        if self.nvalid:
            out.update(bank_mean_deg=math.degrees(self.sum / self.nvalid), bank_min_deg=math.degrees(self.min),
                       bank_max_deg=math.degrees(self.max))
        return out


def unsettled_warnings(source: str, name: str, stats: _BankStats, settle_s: float) -> list[str]:
    """A warning where the estimator ``name`` gave no valid sample, or no settled one (its valid samples all
    within ``settle_s`` seconds of a (re)start, :mod:`roadbank.estimators.settle`): its bank columns may then still
    carry part of the error it started with, which the summary's numbers alone do not say."""
    if stats.n and not stats.nvalid:
        return [f"{source}: {name} gave no valid sample: the log never drives forward at its lowest speed "
                "(or its channels are not finite)"]
    if stats.nvalid and not stats.nsettled:
        return [f"{source}: {name} never settled: no stretch of valid samples lasts its settling time "
                f"({settle_s:.1f} s), so its bank may still carry part of the error of its start (one sample's "
                f"estimate; the column {name}.settled is False throughout)"]
    return []


def concat_estimates(parts: list):
    """One :class:`~roadbank.signals.Estimate` from consecutive chunk estimates."""
    first = parts[0]
    states = {k: np.concatenate([p.states[k] for p in parts]) for k in first.states}
    return Estimate(first.name, np.concatenate([p.t for p in parts]), np.concatenate([p.w for p in parts]),
                    np.concatenate([p.theta for p in parts]), np.concatenate([p.phi_b for p in parts]),
                    np.concatenate([p.valid for p in parts]), states, np.concatenate([p.settled for p in parts]))


def _plot(summary: LogSummary, plot, whole, title: str) -> None:
    """Draw the log's PNG; one that cannot be written is a warning and ``summary.plot_error``, not a failed
    log: its table is written."""
    from ..report.timeseries import plot_estimates

    t, series, roll, truth = whole
    try:
        plot_estimates(plot, t, series, roll, title=title, truth=truth)
    except (OSError, ValueError) as exc:
        why = str(write_error(plot, exc)) if isinstance(exc, OSError) else f"cannot write '{plot}': {exc}"
        summary.plot_error = why
        summary.warnings = "; ".join(filter(None, [summary.warnings, f"plot not written: {why} (the table "
                                                                     f"{summary.output} was written)"]))


def estimate_log(path, output, estimators=(DEFAULT,), *, channels=None, format: str | None = None,
                 params=None, vehicle=None, chunk_rows: int | None = None, metadata: dict | None = None,
                 keep: bool = False, plot=None, online_offsets: bool = True) -> LogSummary:
    """Estimate the bank on one log, streamed in chunks, and write the result table incrementally.

    Parameters
    ----------
    path : path-like
        The log (any format :func:`roadbank.io.load_log` reads; Parquet and MDF4 are streamed).
    output : path-like
        ``.csv`` or ``.parquet`` result table: ``t`` (s), ``<est>.theta``, ``<est>.phi_b`` (rad),
        ``<est>.valid``, ``<est>.settled``, [``reference_roll`` (rad)] (see :mod:`roadbank.io.writers`).
    estimators : sequence of str
        Estimator names (:data:`roadbank.estimators.NAMES`); the first one is summarised.
    channels, format, params
        As for :func:`roadbank.io.load_log`.
    vehicle : roadbank.vehicle.Vehicle, str or Path, optional
        Builds the estimators (its parameters, sensors and tuning) and supplies ``params``.
        The estimators are built on the first chunk, for the log's sample rate and ``ay``
        noise (:func:`roadbank.vehicle.make_estimator` with
        :func:`~roadbank.vehicle.log_conditions`): a default-tuned PIF's ``R`` is the car's
        yaw-rate sensor (without ``vehicle``: the paper's ESP sensor) at the rate the log is
        sampled at (10 Hz KITTI frames, a 50 Hz CSV, ...), its ``Q_ay`` the accelerometer's
        or the white noise measured on the chunk's ``ay``, whichever is larger. Its
        identified sensor offsets (``[identified]`` yaw-rate, ay and steering offsets) are
        subtracted from every chunk first (:meth:`roadbank.vehicle.Vehicle.correct`).
    chunk_rows : int, optional
        Rows per chunk (default :data:`roadbank.io.stream.CHUNK_ROWS`).
    metadata : dict, optional
        Written into the Parquet schema.
    keep : bool
        Also keep the whole series in ``summary.kept`` = ``(t, [Estimate], reference_roll, truth)``
        (memory then grows with the log).
    plot : path-like, optional
        Draw theta / phi_b against time into this PNG (keeps the whole series). A PNG that cannot be
        written leaves the log "ok" (its table is written): a warning and ``plot_error`` say why.
    online_offsets : bool
        Learn the yaw-rate and steering offsets while the log runs (at standstill, on straights:
        :func:`roadbank.estimators.with_online_offsets`) and remove them before every estimator.

    Returns
    -------
    LogSummary
        Never raises for a bad log: ``status = "error"`` and ``error`` say why,
        and no partial output file is left behind.
    """
    t_start = time.perf_counter()
    names = list(estimators)
    summary = LogSummary(log=str(path), estimator=names[0] if names else "")
    writer = None
    try:
        if vehicle is not None:
            vehicle = load_vehicle(vehicle)         # a Vehicle, a built-in car's name or a vehicle file's path
            params = vehicle.params
        keep = keep or plot is not None
        stats = [_BankStats() for _ in names]
        warns: list[str] = []
        ests = []
        kept_t: list[np.ndarray] = []
        kept_est: list[list] = [[] for _ in names]
        kept_roll: list[np.ndarray] = []
        kept_truth: dict[str, list[np.ndarray]] = {}
        writer = TableWriter(output, metadata=metadata)
        correct = (lambda s: s) if vehicle is None else vehicle.correct
        # an offline estimator smooths each chunk with the chunks after it as lookahead (as many as
        # cover its lookahead_s: what makes the chunked result that of one run)
        chunks = ReadAhead(stream_log(path, channels=channels, format=format,
                                      params=params if params is not None else undescribed_params(),
                                      chunk_rows=chunk_rows or CHUNK_ROWS))
        span = None
        road = None                 # whether a log designed quiet stays so (for the estimators that change there)
        for k, chunk in enumerate(chunks):
            if k == 0:  # designed for the log's own rate and road noise, measured on its first minute of driving
                lead = chunks.leading(chunk.signals, DESIGN_MAX_S, has_design_span)
                cond = log_conditions(lead)
                car, summary.design = car_for_log(lead, cond, params, vehicle)
                described = vehicle is not None or params is not None
                ests = [for_conditions(n, cond, car, vehicle=vehicle, described=described) for n in names]
                slope, ins = summary.design.get("roll_rate"), bool(summary.design.get("roll_rate_unbiased"))
                if keeps_cars_model(summary.design["quiet"], slope, ins) and any(
                        n in QUIET_MODELS and models_car(n, described) and (n in OFFLINE or not hands_over(slope))
                        for n in names):
                    road = RoadCheck(design_ay_floor(lead))     # (one that hands over reads its roads itself)
                if online_offsets:      # causal ones: a smoother's later samples would see later offsets
                    ests = [e if n in OFFLINE else with_online_offsets(e, car) for e, n in zip(ests, names)]
                span = max((e.lookahead_s for e, n in zip(ests, names) if n in OFFLINE), default=None)
            warns += chunk.warnings
            summary.time_repairs = add_counts(summary.time_repairs, chunk.time_repairs)
            summary.time_repairs_by_channel = add_channel_counts(summary.time_repairs_by_channel,
                                                                 chunk.time_repairs_by_channel)
            signals = correct(chunk.signals)
            if road is not None:
                road.add(signals)
            nxt = None if span is None else chunks.following(span)
            ahead = None if nxt is None else correct(nxt)
            results = [e.run(signals, reset=(k == 0), lookahead=ahead) for e in ests]
            writer.write(estimate_table(chunk.signals.t, results, chunk.reference_roll))
            for st, r in zip(stats, results):
                st.add(r)
            summary.chunks += 1
            if keep:
                kept_t.append(chunk.signals.t)
                for lst, r in zip(kept_est, results):
                    lst.append(r)
                if chunk.reference_roll is not None:
                    kept_roll.append(chunk.reference_roll)
                for c, v in chunk.truth.items():
                    kept_truth.setdefault(c, []).append(v)
        summary.output = str(writer.close())
        if stats:
            stats[0].fill(summary)
        summary.estimators = {n: st.stats() for n, st in zip(names, stats)}
        if stats:
            warns += unsettled_warnings(str(path), names[0], stats[0], ests[0].settle_time)
        handed = {n: (e.handed_at, e.handed_to) for n, e in zip(names, ests)
                  if math.isfinite(getattr(e, "handed_at", math.nan))}
        if handed:
            warns += handed_over_warnings(str(path), handed, float(stats[0].t0))
            summary.design["handed_over_s"] = float(f"{min(at for at, _ in handed.values()) - stats[0].t0:.4g}")
        if road is not None:
            kept = [n for n in names if n not in handed and models_car(n, described)]
            warns += louder_warnings(str(path), kept, summary.design.get("roll_rate"), *road.finish())
        summary.warnings = "; ".join(warns)
        if keep:
            whole = (np.concatenate(kept_t), [concat_estimates(x) for x in kept_est],
                     np.concatenate(kept_roll) if kept_roll else None,
                     {c: np.concatenate(v) for c, v in kept_truth.items()})
            summary.kept = whole
            if plot is not None:
                _plot(summary, plot, whole, str(path))
    except (LogError, ValueError, OSError) as exc:
        summary.status, summary.error = "error", str(exc)
    except Exception as exc:  # never a traceback for one bad file
        summary.status, summary.error = "error", f"{type(exc).__name__}: {exc}"
    if summary.status == "error" and writer is not None:
        writer.abort()
    summary.seconds = time.perf_counter() - t_start
    return summary
