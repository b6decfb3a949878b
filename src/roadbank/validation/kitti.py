"""Score every estimator against the INS roll of KITTI raw drives.

The scoring is :mod:`roadbank.validation.scoring`, the same as for comma2k19
(speed gate 5 m/s, 5 s warm-up, zero-phase smoothing tau = 2/3 s, r and RMS of
``theta``, smoothed and raw). Specific to KITTI:

* the warm-up is the drive's first 5 s (:data:`KITTI_SCORING`): the seconds
  after each stop are scored, as a user reads them; the split tables also give the raw RMS
  with a warm-up after each start (:data:`KITTI_SCORING_EACH_START`);

* reader :func:`roadbank.io.kitti.load_kitti_oxts`: the frames stay on their
  own jittered 10 Hz time stamps (nothing resampled);
* **no offset is fitted** (``fit_fraction = 0``): the reference roll, the lateral
  specific force and the yaw rate are outputs of the same INS in the same
  vehicle-aligned frame, so there is no mounting offset between them; every
  scored sample counts, and a constant bias of an estimator shows in its RMS;
* the INS signals carry no vibration worth the name (an RT3003's filtered
  outputs), so the raw (unsmoothed) scores are meaningful here; the accuracy
  targets on real data are judged on the raw RMS, and the smoothed scores are reported too;
* no steering angle: the estimators that read it (dfc, uio, pio-original,
  pif-original, kalman) flag every sample not valid and get no score.

The drives are validation data: nothing (no estimator weight, no setting) is
chosen from these results.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cache import not_stored
from ..defaults import ESTIMATOR as DEFAULT
from ..estimators import NoStabilisingSolution
from ..estimators.pif import SENSOR_R_ESTIMATORS
from ..io import LogError
from ..io.kitti import drive_name, find_oxts_dirs, load_kitti_oxts
from ..models.attitude import kinematic_roll
from ..params import VehicleParams
from ..signals import sample_rate
from ..vehicle import SensorSpec, car_for_log, log_conditions, noise_densities, tuning_of
from .comma2k19 import ValidationResult
from .datasets import find_datasets
from .roads import SMOOTH_ROADS, smooth_road
from .scoring import (ESP_DEFAULT, SHORT_PIECES_S, VALIDATION_NAMES, Scoring, _rms_deg, hold_invalid, lowpass_t, masks,
                      pooled, run_and_score, scored_pieces)
from .splits import split_of

#: KITTI scoring: no offset fitted (reference and inputs come from one INS frame), the warm-up the
#: drive's first 5 s: every later sample at vx >= 5 m/s is scored, the seconds after each stop too
#: (what a user reads after pulling away; the real-road target's own scoring)
KITTI_SCORING = Scoring(fit_fraction=0.0, from_log_start=True)
#: the same with the warm-up after each start (after each stop longer than 1 s): the seconds after
#: pulling away are not scored (the scoring before the target's was matched)
KITTI_SCORING_EACH_START = Scoring(fit_fraction=0.0)
#: largest credible RMS (m/s) of the INS's leftward ground speed while driving (vx >= 5 m/s): a
#: car's sideslip velocity is a few tenths of a m/s in ordinary driving (the 16 shared drives:
#: 0.02-0.11 m/s); an INS that reports more has lost its heading or its alignment, and its roll
#: is no reference
MAX_INS_LATERAL_SPEED = 1.0


def ins_doubt(log, v_gate: float = 5.0) -> str | None:
    """Why the drive's INS is not a credible reference, or None (see :data:`MAX_INS_LATERAL_SPEED`)."""
    vl = log.extra.get("vl_mps")
    if vl is None:
        return None
    moving = np.isfinite(vl) & (log.signals.vx >= v_gate)
    if moving.sum() < 10:
        return None
    rms = float(np.sqrt(np.mean(vl[moving] ** 2)))
    if rms > MAX_INS_LATERAL_SPEED:
        return (f"INS leftward speed {rms:.1f} m/s RMS while driving (a car's sideslip is a few tenths; "
                f"above {MAX_INS_LATERAL_SPEED:g} m/s the INS roll is not credible)")
    return None


@dataclass
class KittiValidation:
    """Per-drive results, the pooled scores and the drives that could not be read.

    ``pooled`` is over the credible drives; ``by_split`` gives, for each of ``"training"``,
    ``"validation"`` and ``"unseen"`` (:mod:`roadbank.validation.splits`) present, the drive
    labels, the pooled scores and each estimator's median raw RMS (deg) over its drives;
    ``flagged`` lists ``(drive, reason)`` for the drives whose INS is not credible
    (:func:`ins_doubt`), scored but kept out of every pooled and median score; ``figures`` maps
    each drive label to its figure, when :func:`validate_kitti` was given one to draw.

    ``excluded`` lists ``(drive, path, reason)`` for every drive that could not be read or scored
    (``drive`` the folder's name, None for a path that holds no KITTI folder at all; ``reason``
    names the file and what is wrong with it): not scored, in no pooled score. ``errors`` says the
    same in one line each (``"drive NAME excluded: REASON"``). ``notes`` are what was read but is
    worth a word: a drive given more than once (scored once), two folders of one drive name, a
    drive's reader warnings (a frame file missing from the numbering).
    """

    drives: list[ValidationResult]
    pooled: dict
    errors: list[str] = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    by_split: dict = field(default_factory=dict)
    flagged: list = field(default_factory=list)
    figures: dict = field(default_factory=dict)
    excluded: list = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def kinematic_residual(signals, ref, mask, taus) -> dict:
    """RMS (deg) over ``mask`` of kinematic theta minus ``ref`` (rad), after a zero-phase low-pass of each
    tau (s; 0 = none)."""
    kin = kinematic_roll(signals.vx, signals.ay, signals.r)
    e = hold_invalid(kin - ref)
    out = {}
    for tau in taus:
        x = lowpass_t(e, signals.t, tau) if tau > 0 else e
        out[tau] = float(np.degrees(np.sqrt(np.mean(x[mask] ** 2)))) if mask.any() else float("nan")
    return out


def drive_data(log, run, scoring: Scoring) -> dict:
    """Description numbers of one drive (SI unless the key says deg)."""
    s = log.signals
    dt = np.diff(s.t)
    ref = np.degrees(log.reference_roll)
    gate = s.vx >= scoring.v_gate
    return {"duration_s": float(s.t[-1] - s.t[0]), "frames": len(s),
            "dropped_frames": int(log.metadata.get("dropped_frames", 0)),
            "dt_range": (float(dt.min()), float(dt.max())), "dt_median": float(np.median(dt)),
            "speed_range": (float(np.nanmin(s.vx)), float(np.nanmax(s.vx))),
            "ref_range_deg": (float(ref.min()), float(ref.max())),
            "yaw_rate_max": float(np.nanmax(np.abs(s.r))),
            "gated_fraction": float(np.mean(gate)), "scored_fraction": float(np.mean(run.scored)),
            "scored_s": float(np.sum(np.r_[dt, dt[-1]][run.scored])),
            "ref_std_deg_scored": float(np.std(ref[run.scored])) if run.scored.any() else float("nan"),
            # sample-to-sample noise of ay (white part: std of the difference / sqrt 2), m/s^2
            "ay_noise_std": (float(np.std(np.diff(s.ay[run.scored])) / np.sqrt(2)) if run.scored.sum() > 2
                             else float("nan")),
            # kinematic residual (deg RMS over the scored samples) after low-passes of growing tau (s)
            "kin_residual_deg": kinematic_residual(s, log.reference_roll, run.scored, (0.0, 0.1, 0.3, 1.0)),
            "lat_lon": (log.extra.get("lat_deg"), log.extra.get("lon_deg"))}


def rms_each_start(run, vx) -> dict[str, float]:
    """Raw RMS error (deg) of each estimate of ``run`` (a :class:`~roadbank.validation.scoring.Scored`)
    on the samples of :data:`KITTI_SCORING_EACH_START`: the seconds after each stop not scored; ``vx``
    (m/s) the drive's speed."""
    m = masks(run.t, vx, KITTI_SCORING_EACH_START)[1]
    return {n: _rms_deg(th[m] - run.raw_reference[m]) for n, th in run.raw_estimates.items()}


def validate_kitti_drive(path, names=None, params: VehicleParams | None = None,
                         scoring: Scoring = KITTI_SCORING, sensitivity: bool = True,
                         tuning=None, sensors=None, trim: bool = True) -> ValidationResult:
    """Run every estimator on one KITTI drive and score ``theta`` against the INS roll.

    Parameters
    ----------
    path : path-like
        The drive folder (or its ``oxts`` folder).
    names : sequence of str, optional
        Estimators (default: all of :data:`roadbank.estimators.NAMES` and the default without the roll rate,
        :data:`~roadbank.validation.scoring.VALIDATION_NAMES`).
    params : VehicleParams, optional
        The car; default the rule for a car that is not described
        (:func:`roadbank.vehicle.undescribed_params`, as every command uses).
    scoring : Scoring
        Default :data:`KITTI_SCORING`.
    sensitivity : bool
        Also score with the paper's SUV parameters (``VehicleParams()``, ``sensitivity["suv"]``)
        and the sensor-weighted PIFs designed from the data sheet alone: for the drive's rate
        without the ``ay`` noise measured on it (``sensitivity["sheet_rate"]``), and for the
        sensor's nominal rate (``sensitivity["R_nominal"]``, what ``estimators.make`` builds).
    tuning : mapping, optional
        ``{estimator: {option: value}}`` (a vehicle file's ``[tuning]``), read as ``roadbank estimate --vehicle``
        reads it (:func:`roadbank.vehicle.tuning_of`): the main scores, the short pieces and the smooth roads, and the
        rear trim's trial designs.
    sensors : roadbank.vehicle.SensorSpec, optional
        The car's sensors (a vehicle file's ``[sensors]``): the default PIFs' ``R`` is their
        noise density at the drive's rate (:func:`roadbank.vehicle.make_estimator`).
    trim : bool
        With ``params``: whether its rear cornering stiffness is trimmed to each drive and piece
        (:func:`roadbank.vehicle.described_car`; False for a stiffness measured on the car,
        :func:`roadbank.vehicle.trims_rear`).

    Raises
    ------
    LogError
        The drive cannot be read (:func:`roadbank.io.kitti.load_kitti_oxts`: the message names the
        file and what is wrong), or it has no sample to score (shorter than the warm-up, or never at
        the speed gate): nothing of it could count.
    """
    names = list(names or VALIDATION_NAMES)
    log = load_kitti_oxts(path)
    if not masks(log.signals.t, log.signals.vx, scoring)[1].any():
        s = log.signals
        raise LogError(f"{path}: no sample to score: {len(s)} frames over {s.t[-1] - s.t[0]:.1f} s, speed at most "
                       f"{np.nanmax(s.vx, initial=0.0):.1f} m/s (scored: vx >= {scoring.v_gate:g} m/s after the "
                       f"first {scoring.warmup_s:g} s)")
    given = params
    # a car not described: the one that fits the drive
    run, params, design = _scored_as_log(log.signals, log.reference_roll, names, given, scoring, sensors, trim, tuning)
    sens: dict = {}
    notes: list[str] = []
    if sensitivity:
        sens["suv"] = run_and_score(log.signals, log.reference_roll, names, VehicleParams(), scoring).scores
        # the sensor-weighted PIFs designed from the data sheet alone: at the drive's rate, and at
        # the sensor's nominal rate (100 Hz)
        spec = sensors or SensorSpec()
        at_rate = [n for n in names if n in SENSOR_R_ESTIMATORS and "R" not in tuning_of(tuning or {}, n)]
        sheets = {}
        try:
            for key, rate in (("sheet_rate", sample_rate(log.signals.t)), ("R_nominal", None)) if at_rate else ():
                R, Q_ay = noise_densities(spec, rate)          # the data sheet's: no log noise given
                sheet = {"R": R, "Q_ay": Q_ay}
                sheets[key] = run_and_score(log.signals, log.reference_roll, at_rate, params, scoring,
                                            per_estimator={n: {**tuning_of(tuning or {}, n), **sheet}
                                                           for n in at_rate}).scores
            sens.update(sheets)
        except NoStabilisingSolution as exc:    # a diagnostic: the drive's scores stand without it
            notes.append(f"the sensor-weighted PIFs from the data sheet alone are not scored: {exc}")
    t = log.signals.t
    first = np.flatnonzero(run.scored)
    settings = {"tau": scoring.tau, "warmup_s": scoring.warmup_s, "fit_fraction": scoring.fit_fraction,
                "v_gate": scoring.v_gate, "from_log_start": scoring.from_log_start,
                "dt": float(np.median(np.diff(t))), "path": str(path)}
    data = drive_data(log, run, scoring)
    data["rms_raw_each_start_deg"] = rms_each_start(run, log.signals.vx)
    data["split"] = split_of(log.metadata["drive"])
    data["ins_doubt"] = ins_doubt(log, scoring.v_gate)
    data["design"] = design
    data["warnings"] = list(log.warnings) + notes
    if sensitivity:
        data["pieces"] = short_log_scores(log, [n for n in SHORT_NAMES if n in names], given, scoring, sensors, trim,
                                          tuning, data["warnings"])
        data["smooth_roads"] = smooth_road_scores(log, [n for n in SMOOTH_NAMES if n in names], given, scoring,
                                                  sensors, trim, tuning, data["warnings"])
    return ValidationResult(scores=run.scores, params=params, t=t, reference=run.reference,
                            estimates=run.estimates, split_time=float(t[first[0]]) if len(first) else float(t[0]),
                            data=data, sensitivity=sens, settings=settings, run=run,
                            label=log.metadata["drive"], dataset="kitti", valid=run.valid)


def _scored_as_log(signals, ref, names, params, scoring: Scoring, sensors, trim: bool, tuning):
    """``(run, car, design)``: ``signals`` read as a log of its own, as ``roadbank estimate`` reads it: its car
    (:func:`roadbank.vehicle.car_for_log`: ``params``, with ``sensors`` and ``tuning``, trimmed to it unless ``trim`` is
    False; None: the shipped car that fits it) and its design record, and each estimator of ``names`` designed for
    it and scored against ``ref`` (:func:`~roadbank.validation.scoring.run_and_score`)."""
    car, design = car_for_log(signals, log_conditions(signals), params, sensors=sensors, trim=trim, tuning=tuning)
    run = run_and_score(signals, ref, names, car, scoring, per_estimator=tuning, sensors=sensors,
                        described=params is not None)
    return run, car, design


#: the estimators scored on a drive's short pieces (:func:`short_log_scores`): the baselines, the default, and the
#: default without the roll rate
SHORT_NAMES = ("kinematic", "kinematic-lp", DEFAULT, ESP_DEFAULT)


def short_log_scores(log, names, params: VehicleParams | None, scoring: Scoring, sensors=None,
                     trim: bool = True, tuning=None, notes: list | None = None) -> dict:
    """``{length: {name: [raw RMS deg per piece]}}``: each estimator of ``names`` on the consecutive whole pieces of
    each of :data:`SHORT_PIECES_S` (s) of the drive ``log`` (:func:`~roadbank.validation.scoring.piece_bounds`), each
    piece read as a log of its own (its design, its fitted car unless ``params`` is given, ``scoring`` within it);
    pieces with no scored sample left out. What a user with a short log gets. Their designs (one set per piece) are
    not written to the design cache (:func:`roadbank.cache.not_stored`): they would fill it. ``sensors``, ``trim`` and
    ``tuning``: as :func:`validate_kitti_drive`. A piece on which an estimator has no stabilising design (a car's
    tuning too tight for that piece's noise) is left out, said in ``notes`` (a list, appended to)."""
    with not_stored():
        return {length: _piece_scores(log, length, names, params, scoring, sensors, trim, tuning,
                                      notes if notes is not None else [])
                for length in SHORT_PIECES_S}


def _piece_scores(log, length: float, names, params, scoring: Scoring, sensors, trim: bool, tuning,
                  notes: list) -> dict:
    """:func:`short_log_scores` for one piece ``length`` (s): ``{name: [raw RMS deg per piece]}``."""
    rms: dict = {n: [] for n in names}
    left_out = []
    for a, b, piece, _ in scored_pieces(log.signals, length, scoring):
        try:
            run = _scored_as_log(piece, log.reference_roll[a:b], names, params, scoring, sensors, trim, tuning)[0]
        except NoStabilisingSolution as exc:
            left_out.append(exc)
            continue
        for n in names:
            rms[n].append(run.scores[n].rms_raw_deg)
    if left_out:
        notes.append(f"{len(left_out)} of its {length:g} s pieces left out: {left_out[0]}")
    return rms


#: the estimators scored on a drive made a smooth road (:func:`smooth_road_scores`): those of the short pieces and the
#: car's model (``pif-adaptive``, the default's quiet filter for a car described)
SMOOTH_NAMES = SHORT_NAMES + ("pif-adaptive",)


def smooth_road_scores(log, names, params: VehicleParams | None, scoring: Scoring, sensors=None,
                       trim: bool = True, tuning=None, notes: list | None = None) -> dict:
    """``{form: {name: raw RMS deg}}``: each estimator of ``names`` on the drive ``log`` as each smooth road of
    :data:`roadbank.validation.roads.SMOOTH_ROADS` (:func:`~roadbank.validation.roads.smooth_road`, seed 0), read as a
    log of its own (its design and fitted car unless ``params`` is given): what a quiet log of the same drive gives.
    Its designs are not written to the design cache. ``sensors``, ``trim`` and ``tuning``: as
    :func:`validate_kitti_drive`. A road on which an estimator has no stabilising design scores NaN for every
    estimator, said in ``notes`` (a list, appended to)."""
    out = {}
    with not_stored():
        for form, (order, cutoff) in SMOOTH_ROADS.items():
            s = smooth_road(log.signals, order, cutoff, seed=0)
            try:
                run = _scored_as_log(s, log.reference_roll, names, params, scoring, sensors, trim, tuning)[0]
            except NoStabilisingSolution as exc:
                if notes is not None:
                    notes.append(f"not scored as the smooth road {form}: {exc}")
                out[form] = {n: math.nan for n in names}
                continue
            out[form] = {n: run.scores[n].rms_raw_deg for n in names}
    return out


def _smooth_split(ds, names) -> dict:
    """``{form: {"drives": n, "median_rms_raw_deg": {name: deg}, "default_below_lp": k}}`` over the drives ``ds`` made
    a smooth road (:func:`smooth_road_scores`, in ``data["smooth_roads"]``); empty when none has them."""
    ds = [d for d in ds if "smooth_roads" in d.data]
    out = {}
    for form in SMOOTH_ROADS if ds and names else ():
        per = {n: [d.data["smooth_roads"][form][n] for d in ds] for n in names}
        pairs = zip(per.get(ESP_DEFAULT, []), per.get("kinematic-lp", []))
        out[form] = {"drives": len(ds), "median_rms_raw_deg": {n: _median(v) for n, v in per.items()},
                     "default_below_lp": sum(a < b for a, b in pairs)}
    return out


def _short_split(ds, names) -> dict:
    """``{length: {"pieces": n, "median_rms_raw_deg": {name: deg}, "default_below_lp": k}}`` over the short pieces of
    the drives ``ds`` (:func:`short_log_scores`, in ``data["pieces"]``); empty when none has them."""
    ds = [d for d in ds if "pieces" in d.data]
    out = {}
    for length in SHORT_PIECES_S:
        per = {n: [x for d in ds for x in d.data["pieces"][length].get(n, [])] for n in names}
        if ds and names and per[names[0]]:
            pairs = zip(per.get(DEFAULT, []), per.get("kinematic-lp", []))
            out[length] = {"pieces": len(per[names[0]]), "median_rms_raw_deg": {n: _median(v) for n, v in per.items()},
                           "default_below_lp": sum(a < b for a, b in pairs)}
    return out


def expand_drives(paths) -> list[Path]:
    """Each path as given when it is one drive (a drive folder or its ``oxts`` folder), else every drive
    folder under it at any depth (:func:`roadbank.validation.datasets.find_datasets`, as ``validate all`` finds
    them; a drive a level further down was passed over before).

    A drive folder whose ``oxts`` folder lacks ``timestamps.txt`` or ``data/``
    (:func:`roadbank.io.kitti.find_oxts_dirs` with ``broken=True``) is listed too, so that reading it
    reports what is missing rather than passing it over; a path with no KITTI folder at all is kept as
    given (reading it says so).
    """
    return [d for _, d in _expanded(paths)[0]]


def _expanded(paths) -> tuple[list[tuple[Path, Path]], list[str]]:
    """``(path given, drive path)`` of each drive of :func:`expand_drives`, and the search's notes (a folder that
    could not be listed, folders too deep)."""
    out, notes = [], []
    for p in map(Path, paths):
        found = None if find_oxts_dirs(p, broken=True) in ([p], [p / "oxts"]) or not p.is_dir() else find_datasets(p)
        if found is None or not found["kitti"]:
            out.append((p, p))
        else:
            out += [(p, d) for d in found["kitti"]]
            notes += found["notes"]
    return out, notes


def _same_folder(path: Path) -> Path:
    """The folder of the drive at ``path`` with every link resolved (its ``oxts`` folder's parent when
    ``path`` is that folder): two paths to one drive give the same."""
    r = path.resolve()
    return r.parent if r.name == "oxts" else r


def _drive_label(path: Path) -> str | None:
    """The name a drive at ``path`` is reported under (its folder's name), or None when ``path`` holds no
    KITTI folder at all."""
    found = find_oxts_dirs(path, broken=True)
    return drive_name(found[0]) if len(found) == 1 else None


def unique_drives(paths) -> tuple[list[Path], list[str]]:
    """:func:`expand_drives` of ``paths`` with each drive once, and notes on what was left out.

    Parameters
    ----------
    paths : sequence of path-like
        Drive folders, oxts folders, or folders holding drive folders.

    Returns
    -------
    drives : list of Path
        In the order given; a drive reached a second time (the same folder once links are resolved,
        e.g. a folder of drives and one of its drives both given) is left out.
    notes : list of str
        One per drive left out, naming it and how it was reached both times.
    """
    kept: dict[Path, tuple[Path, Path]] = {}
    expanded, notes = _expanded(paths)
    for given, p in expanded:
        key = _same_folder(p)
        label = _drive_label(p)
        if key in kept:
            how = [f"as {d}" if g == d else f"in {g}" for g, d in (kept[key], (given, p))]
            notes.append(f"drive {label or p.name} given more than once ({how[0]}, then {how[1]}; the same "
                         f"folder {key}): scored once")
            continue
        kept[key] = (given, p)
    return [p for _, p in kept.values()], notes


def _drive_outcome(path, names, params, scoring, sensitivity, tuning, sensors, trim=True, figure=None):
    """``(ValidationResult, None, figure)`` of one drive (``figure(result)``, or None without
    ``figure``), or ``(None, reason, None)`` when it cannot be read or scored: one task of
    :func:`validate_kitti` (in this process or on a worker).

    A malformed drive is a :class:`~roadbank.io.LogError` (its message names the file and the line);
    any other failure is reported with its type, so one drive never stops the others.
    """
    try:
        res = validate_kitti_drive(path, names, params, scoring, sensitivity, tuning, sensors, trim)
    except (LogError, OSError) as exc:
        return None, str(exc), None
    except Exception as exc:        # a drive the reader took but the scoring could not: still one drive
        return None, f"{path}: {type(exc).__name__}: {exc}", None
    return res, None, (None if figure is None else figure(res))


def _collected(pool, path, task):
    """:func:`_drive_outcome` of a drive's pool task; a task that failed on its worker gives the reason."""
    value, failure = pool.outcome(task)
    return value if failure is None else (None, f"{path}: {failure}", None)


def drive_frames(path) -> int:
    """Number of frames of a drive folder (or its ``oxts`` folder): the files in ``oxts/data`` (0 when
    that folder cannot be listed). What a drive's task costs grows with it."""
    for d in (Path(path) / "oxts" / "data", Path(path) / "data"):
        try:
            with os.scandir(d) as it:
                return sum(1 for _ in it)
        except OSError:
            continue
    return 0


def validate_kitti(paths, names=None, params: VehicleParams | None = None,
                   scoring: Scoring = KITTI_SCORING, sensitivity: bool = True,
                   tuning=None, sensors=None, trim: bool = True, pool=None, figure=None) -> KittiValidation:
    """Validate any number of KITTI drives; a drive that cannot be read is reported, the others go on.

    Parameters
    ----------
    paths : sequence of path-like
        Drive folders, oxts folders, or folders holding drive folders.
    names, params, scoring, sensitivity, tuning, sensors, trim
        As :func:`validate_kitti_drive`.
    pool : optional
        Where the drives run, one task each (a pool of :func:`roadbank.fleet.cluster.open_pool`;
        default: one after another in this process). The results are taken in the order of the drives,
        so the validation is the same on any number of workers; a drive whose worker failed is
        reported with the reason. The longest drives (:func:`drive_frames`) are submitted first, so
        that no worker is left with a long one at the end while the others wait.
        A drive reached twice (:func:`unique_drives`) runs once, with a note.
    figure : callable, optional
        ``figure(result)``: a drive's figure drawn in its task, so on its worker (e.g. the PNG bytes of
        :func:`roadbank.validation.kitti_report.drive_png`; a module-level function for a pool); what
        it returns goes to ``figures`` under the drive's label.
    """
    names = list(names or VALIDATION_NAMES)
    drives, errors, figures, excluded = [], [], {}, []
    expanded, notes = unique_drives(paths)
    args = (names, params, scoring, sensitivity, tuning, sensors, trim, figure)
    if pool is None:
        outcomes = (_drive_outcome(p, *args) for p in expanded)
    else:
        frames = [0 if pool.in_process else drive_frames(p) for p in expanded]
        tasks = {}
        for i in sorted(range(len(expanded)), key=lambda i: -frames[i]):
            tasks[i] = pool.submit(_drive_outcome, expanded[i], *args)
        outcomes = (_collected(pool, p, tasks[i]) for i, p in enumerate(expanded))
    for path, (res, error, fig) in zip(expanded, outcomes):
        if error is not None:
            label = _drive_label(path)
            excluded.append((label, str(path), error))
            errors.append(error if label is None else f"drive {label} excluded: {error}")
        else:
            drives.append(res)
            notes += [f"drive {res.label}: {w}" for w in res.data.get("warnings", ())]
            if fig is not None:
                figures[res.label] = fig
    for label in sorted({d.label for d in drives if sum(e.label == d.label for e in drives) > 1}):
        where = " and ".join(d.settings["path"] for d in drives if d.label == label)
        notes.append(f"two folders hold a drive named {label} ({where}): both scored under that name (one "
                     "figure); a copy of one drive counts twice in the pooled scores")
    credible = [d for d in drives if not d.data.get("ins_doubt")]
    by_split = {}
    for split in ("training", "validation", "unseen"):
        ds = [d for d in credible if d.data["split"] == split]
        if ds:
            by_split[split] = {"drives": [d.label for d in ds], "pooled": pooled([d.run for d in ds], names),
                               "median_rms_raw_deg": {n: _median([d.scores[n].rms_raw_deg for d in ds])
                                                      for n in names},
                               "median_rms_raw_each_start_deg": {n: _median([d.data["rms_raw_each_start_deg"][n]
                                                                             for d in ds]) for n in names},
                               "short_logs": _short_split(ds, [n for n in SHORT_NAMES if n in names]),
                               "smooth_roads": _smooth_split(ds, [n for n in SMOOTH_NAMES if n in names])}
    return KittiValidation(drives=drives, pooled=pooled([d.run for d in credible], names), errors=errors,
                           settings={"tau": scoring.tau, "warmup_s": scoring.warmup_s,
                                     "v_gate": scoring.v_gate, "fit_fraction": scoring.fit_fraction,
                                     "from_log_start": scoring.from_log_start},
                           by_split=by_split, flagged=[(d.label, d.data["ins_doubt"]) for d in drives
                                                       if d.data.get("ins_doubt")], figures=figures,
                           excluded=excluded, notes=notes)


def below_kinematic(drives, name: str) -> tuple[int, int]:
    """On how many of ``drives`` (:class:`~roadbank.validation.comma2k19.ValidationResult` with ``kinematic`` and
    ``name`` scored) ``name``'s raw RMS is below the raw kinematic estimate's, and of how many it has a score."""
    pairs = [(d.scores[name].rms_raw_deg, d.scores["kinematic"].rms_raw_deg) for d in drives
             if "kinematic" in d.scores and name in d.scores and math.isfinite(d.scores[name].rms_raw_deg)]
    return sum(a < b for a, b in pairs), len(pairs)


def _median(values) -> float:
    v = [x for x in values if np.isfinite(x)]
    return float(np.median(v)) if v else float("nan")
