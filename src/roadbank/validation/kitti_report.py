"""Tables, JSON and figures of the KITTI validation (a section of docs/real-data.md)."""

from __future__ import annotations

import io
import math

from ..constants import G
from ..defaults import ESTIMATOR as DEFAULT
from ..estimators import OFFLINE
from ..report.markdown import md_table
from ..report.tables import targets_markdown
from ..report.timeseries import reference_figure, save_figure
from ..vehicle import QUIET_RATIO
from .kitti import KittiValidation, below_kinematic
from .scoring import ESP_DEFAULT
from .targets import kitti_targets

#: the best value of each score column: smallest RMS, largest correlation
_BEST = {"rms raw (deg)": "min", "r raw": "max", "rms smoothed (deg)": "min", "r smoothed": "max", "r causal LP": "max"}


def _medians_table(parts: dict, label, count: str, heads: list[str], default: str) -> str:
    """The table of a section of medians per split: ``parts`` ``{split: {key: {count: n, "median_rms_raw_deg": {name:
    deg}, "default_below_lp": k}}}``, a row per split and key labelled ``label(split, key)``, ``heads`` the first two
    columns' headings, ``default`` the estimator counted below ``kinematic-lp``."""
    first = next(x for by_key in parts.values() for x in by_key.values())
    names = list(first["median_rms_raw_deg"])
    body = [[label(split, key), int(x[count])] + [x["median_rms_raw_deg"][n] for n in names]
            + [f"{x['default_below_lp']} of {x[count]}"]
            for split, by_key in parts.items() for key, x in by_key.items()]
    return md_table(heads + [f"{n} (deg)" for n in names] + [f"{default} below kinematic-lp"], body, digits=3,
                    align="lr" + "r" * (len(names) + 1))


def short_log_lines(v: KittiValidation, h: str) -> list[str]:
    """The "Short logs" section: per split and piece length, the median raw RMS over the drives' short pieces
    (:func:`roadbank.validation.kitti.short_log_scores`); nothing when no drive has them."""
    parts = {k: part["short_logs"] for k, part in v.by_split.items() if part.get("short_logs")}
    if not parts:
        return []
    return [f"{h}# Short logs\n",
            "Many raw drives last 10-30 s. Each credible drive cut into consecutive whole pieces of 8, 12 and 20 s, "
            "each piece read as a log of its own (its own design and fitted car, the scoring within it), as "
            "`roadbank estimate` reads a short log: median raw theta RMS (deg) over the pieces, and on how many "
            f"pieces the default (`{DEFAULT}`) is below `kinematic-lp`. On a piece too short for the roll-rate "
            "check the format's own roll rate is still used (docs/estimators.md, \"Short logs and a format's own "
            "channels\").\n",
            _medians_table(parts, lambda split, length: f"{split} {length:g} s", "pieces", ["split, piece", "pieces"],
                           DEFAULT), ""]


def smooth_road_lines(v: KittiValidation, h: str) -> list[str]:
    """The "The drives as a smooth road" section: per split and form, the median raw RMS over the drives made a smooth
    road (:func:`roadbank.validation.kitti.smooth_road_scores`); nothing when no drive has them."""
    parts = {k: part["smooth_roads"] for k, part in v.by_split.items() if part.get("smooth_roads")}
    if not parts:
        return []
    return [f"{h}# The drives as a smooth road\n",
            "Every drive here reads loud, so the default's quiet branch would meet no real log. Each credible drive "
            "with its `ay` and yaw rate through a zero-phase Butterworth low-pass (second order at 0.5 Hz; eighth "
            "order at 0.8 Hz, which keeps the car's motion up to about 0.7 Hz) plus the ESP data sheet's noise "
            "(`roadbank.validation.roads.smooth_road`; both read quiet), the INS roll and the speed as recorded, "
            "read as a log of its own: median raw theta RMS (deg) over the drives, and on how many the default "
            f"without the roll rate (`{ESP_DEFAULT}`) is below `kinematic-lp`. No vehicle file: a quiet log of a car "
            "nobody described is designed as a loud one (the sixty-second stage, docs/estimators.md); "
            "`pif-adaptive` is the car's model, what the default was there before (and is with a vehicle file).\n",
            _medians_table(parts, lambda split, form: f"{split}, {form}", "drives", ["split, road", "drives"],
                           ESP_DEFAULT), ""]


def _f(x, nd=3):
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{nd}f}"


def _j(x):
    return None if isinstance(x, float) and math.isnan(x) else round(float(x), 4)


def to_json(v: KittiValidation) -> dict:
    """``{"drives": {drive: {estimator: {...}}}, "pooled": {estimator: {...}}, "errors": [...],
    "excluded": [{"drive", "path", "reason"}], "notes": [...],
    "splits": {split: {"drives", "short_logs", "smooth_roads", "median_rms_raw_deg", "median_rms_raw_each_start_deg",
    "pooled"}},
    "flagged": [{"drive", "reason"}], "designs": {drive: design}}`` (``design``:
    :func:`roadbank.vehicle.design_record`; ``excluded``: the drives not read or not scored, ``drive``
    null for a path that holds no KITTI folder; ``notes``: :attr:`KittiValidation.notes`).

    Per estimator: ``r``, ``rms_deg`` (smoothed), ``r_raw``, ``rms_raw_deg`` (unsmoothed),
    ``rms_raw_each_start_deg`` (unsmoothed, the seconds after each stop not scored:
    :data:`~roadbank.validation.kitti.KITTI_SCORING_EACH_START`), ``offset_deg`` (0: not fitted on KITTI);
    null where the estimator has no valid sample.
    """
    drives = {d.label: {n: {"r": _j(s.r), "rms_deg": _j(s.rms_deg), "r_raw": _j(s.r_raw),
                            "rms_raw_deg": _j(s.rms_raw_deg), "offset_deg": _j(s.offset_deg),
                            "rms_raw_each_start_deg": _j(d.data["rms_raw_each_start_deg"][n])}
                        for n, s in d.scores.items()} for d in v.drives}
    pool = {n: {k: (_j(x) if k != "n" else x) for k, x in p.items()} for n, p in v.pooled.items()}
    splits = {k: {"drives": part["drives"],
                  "short_logs": {f"{length:g}": {"pieces": x["pieces"], "default_below_lp": x["default_below_lp"],
                                                 "median_rms_raw_deg": {n: _j(y) for n, y in
                                                                        x["median_rms_raw_deg"].items()}}
                                 for length, x in part.get("short_logs", {}).items()},
                  "smooth_roads": {form: {"drives": x["drives"], "default_below_lp": x["default_below_lp"],
                                          "median_rms_raw_deg": {n: _j(y) for n, y in x["median_rms_raw_deg"].items()}}
                                   for form, x in part.get("smooth_roads", {}).items()},
                  "median_rms_raw_deg": {n: _j(x) for n, x in part["median_rms_raw_deg"].items()},
                  "median_rms_raw_each_start_deg": {n: _j(x)
                                                    for n, x in part["median_rms_raw_each_start_deg"].items()},
                  "pooled": {n: {k2: (_j(x) if k2 != "n" else x) for k2, x in p.items()}
                             for n, p in part["pooled"].items()}}
              for k, part in v.by_split.items()}
    return {"drives": drives, "pooled": pool, "errors": list(v.errors),
            "excluded": [{"drive": d, "path": p, "reason": why} for d, p, why in v.excluded],
            "notes": list(v.notes), "splits": splits,
            "flagged": [{"drive": d, "reason": why} for d, why in v.flagged],
            "designs": {d.label: {k: _j(x) if isinstance(x, float) else x for k, x in d.data.get("design", {}).items()}
                        for d in v.drives}}


def drive_figure(res, show=("kinematic", "pif-modified", DEFAULT)):
    """Raw theta of some estimators and the INS roll (deg), and their error, against time from the
    drive start (s); unscored spans grey, spans an estimator flagged not valid red (a matplotlib figure)."""
    run = res.run
    names = [n for n in show if n in run.raw_estimates and res.scores[n].valid_fraction > 0]
    return reference_figure(res.t, run.raw_reference, {f"{n} theta": run.raw_estimates[n] for n in names},
                            valid={f"{n} theta": run.valid[n] for n in names if n in run.valid},
                            unscored=~run.scored,
                            quantity="roll", reference_label="INS roll (reference)",
                            title=f"KITTI {res.label}: theta vs INS roll (grey: not scored, vx < 5 m/s or warm-up)")


def plot_drive(res, path, show=("kinematic", "pif-modified", DEFAULT)) -> None:
    """:func:`drive_figure` saved to ``path`` (format from the suffix)."""
    save_figure(drive_figure(res, show), path)


def drive_png(res) -> bytes:
    """:func:`plot_drive` of one drive as the bytes of its PNG file (the same file): what a drive's task
    draws on its worker (``figure`` of :func:`roadbank.validation.kitti.validate_kitti`), for the
    caller to write."""
    buf = io.BytesIO()
    save_figure(drive_figure(res), buf)
    return buf.getvalue()


def figure_name(stem: str, label: str) -> str:
    """File name of a drive's figure next to a report whose file name is ``{stem}.md``."""
    return f"{stem}-kitti-{label}.png"


def _warmup_text(settings: dict) -> str:
    """How the scored samples start, from a validation's ``settings`` (a sentence)."""
    if settings.get("from_log_start"):
        return (f"The first {settings['warmup_s']:g} s of each drive are not scored; after them every sample is, "
                "the seconds after each stop too (what a user reads after pulling away).")
    return (f"A {settings['warmup_s']:g} s warm-up after each start (the first sample above the gate, or after "
            "more than 1 s below it) is not scored.")


def _table(L, rows):
    """Per-estimator scores (best of each score column in bold) appended to the lines ``L``."""
    body = []
    for name, s in rows:
        if s.valid_fraction == 0:
            body.append([name] + [None] * 6 + ["0.00 (needs the steering angle)"])
        else:
            body.append([name, s.rms_raw_deg, s.r_raw, s.rms_deg, s.r, s.r_causal, s.best_lag_s,
                         f"{s.valid_fraction:.2f}"])
    L.append(md_table(["estimator", "rms raw (deg)", "r raw", "rms smoothed (deg)", "r smoothed", "r causal LP",
                       "lag for max r (s)", "valid"], body, digits=3, formats={"lag for max r (s)": "+.2f"},
                      align="lrrrrrrr", best=_BEST, best_in="column"))
    L.append("")


def _design_cell(design: dict) -> str:
    """A drive's :func:`roadbank.vehicle.design_record` in a table cell: car, quiet or loud (floor ratio)."""
    if not design:
        return "-"
    return f"{design['car']}, {'quiet' if design['quiet'] else 'loud'} ({design['ay_floor_ratio']:.2g} x)"


def excluded_lines(v: KittiValidation) -> list[str]:
    """The drives left out (each named, with the file and what is wrong with it) and the notes (a drive
    given twice, a frame file missing), a markdown list; none when there is nothing to say."""
    L = []
    for drive, _, why in v.excluded:         # the reason starts with the path
        L.append(f"- **excluded, not scored**: drive {drive}: {why}" if drive else f"- **not read**: {why}")
    L += [f"- note: {n}" for n in v.notes]
    return L + [""] if L else []


def split_rows(v: KittiValidation, split: str) -> list[list]:
    """Per estimator on one split's credible drives: median and pooled raw RMS (deg), pooled raw r,
    and the share of drives where it is below the raw kinematic estimate."""
    part = v.by_split[split]
    drives = [d for d in v.drives if d.label in part["drives"]]
    rows = []
    for name, med in part["median_rms_raw_deg"].items():
        p = part["pooled"][name]
        if not p["n"]:
            continue
        below, scored = below_kinematic(drives, name)
        rows.append([name + (" (offline)" if name in OFFLINE else ""), med, p["rms_raw_deg"], p["r_raw"],
                     f"{100 * below / scored:.0f} %" if scored and name != "kinematic" else "-",
                     part["median_rms_raw_each_start_deg"][name]])
    return rows


def split_lines(v: KittiValidation, h: str) -> list[str]:
    """The training / validation section: one table per split, the flagged drives."""
    L = [f"{h}# Training and validation drives\n",
         f"Raw theta RMS (deg) against the INS roll at vx >= 5 m/s; the default estimator is `{DEFAULT}`. "
         "Choices were made on the training drives only (docs/estimators.md); the validation drives are "
         f"reported, never used to choose. {_warmup_text(v.settings)} The last column leaves out the 5 s "
         "after each stop longer than 1 s.\n"]
    for split in ("training", "validation", "unseen"):
        if split not in v.by_split:
            continue
        n = len(v.by_split[split]["drives"])
        L.append(f"**{split}** ({n} drive{'s' if n != 1 else ''}):\n")
        L.append(md_table(["estimator", "median rms raw (deg)", "pooled rms raw (deg)", "pooled r raw",
                           "drives below kinematic", "median rms raw, 5 s after each start (deg)"],
                          split_rows(v, split), digits=3,
                          best={"median rms raw (deg)": "min", "pooled rms raw (deg)": "min", "pooled r raw": "max",
                                "median rms raw, 5 s after each start (deg)": "min"},
                          best_in="column"))
        L.append("")
    for label, why in v.flagged:
        L.append(f"- **not pooled**: {label}: {why}")
    if v.flagged:
        L.append("")
    found = kitti_targets(v)
    if found:
        L.append("The default's targets on the validation drives (`roadbank.validation.targets`):\n")
        L += targets_markdown(found)
    return L


def limits_lines(v: KittiValidation, h: str) -> list[str]:
    """"What the data can support": the 10 Hz noise floor of ay and what smoothing does to the kinematic residual."""
    L = [f"{h}# What the data can support\n"]
    for d in v.drives:
        x = d.data
        if "ay_noise_std" not in x:
            continue
        k = x["kin_residual_deg"]
        L.append(f"- {d.label}: the 10 Hz `ay` samples carry {x['ay_noise_std']:.3f} m/s^2 of sample-to-sample "
                 f"noise (std of the difference / sqrt 2), i.e. {math.degrees(x['ay_noise_std'] / G):.2f} deg "
                 f"of bank; the kinematic estimate's raw error is {_f(k.get(0.0))} deg RMS, and the same residual "
                 f"low-passed (zero-phase) is {_f(k.get(0.1))} / {_f(k.get(0.3))} / {_f(k.get(1.0))} deg with "
                 "tau = 0.1 / 0.3 / 1 s.")
    L.append("- So the raw RMS is set by noise above ~1 Hz in the INS's point-sampled `ay`, not by a bias or a "
             "slow error: the raw columns mostly measure how much of that noise an estimator lets through "
             "(its bandwidth at 10 Hz), the smoothed columns how closely it follows the roll without lag. A "
             "causal observer can beat the kinematic estimate on the raw score by filtering; on the smoothed "
             "score it cannot, because the zero-phase smoother gives the kinematic estimate the same filtering "
             "without lag. The `lag for max r` column shows each observer's remaining lag.")
    L.append("- `ay`, `wz` and the reference roll come from one INS (README of the data): a check of real-road "
             "behaviour (crowned roads, turns, 10 Hz jittered sampling, standstill and restarts), not of "
             "ESP-sensor-grade noise or of estimator behaviour with an independent reference.\n")
    return L


def markdown(v: KittiValidation, figures: dict | None = None, level: int = 2) -> str:
    """The KITTI section: per-drive and pooled tables, targets, method, figures (``{drive: file}``)."""
    h = "#" * level
    st = v.settings
    L = [f"{h} KITTI raw drives (OXTS RT3003 GNSS/INS, 10 Hz with jitter)\n"]
    L.append("Data: KITTI raw drives (Karlsruhe), `oxts/` folders as KITTI distributes them; reference = the "
             "INS roll (bank + body roll, ISO, left side up); inputs = the INS forward speed `vf`, lateral "
             "specific force `ay` and yaw rate `wz`. No steering angle. Licence CC BY-NC-SA 3.0 (Geiger, "
             "Lenz, Stiller, Urtasun, IJRR 2013): the data stay outside the repository.\n")
    L.append("Estimators: each designed for the drive as `roadbank estimate` designs it "
             "(`roadbank.vehicle.for_log`): the sensor-weighted PIFs' noise densities follow the log's "
             "sample rate and the road noise measured on its own `ay` and yaw rate (the noise model of real "
             "roads, `roadbank.signals.road_noise_std`; docs/estimators.md); no vehicle file, so the car "
             "for a log whose car is not described. Choices were made on the training drives only.\n")
    L.append(md_table(["drive", "duration (s)", "frames (dropped)", "step (s)", "speed (m/s)", "roll (deg)",
                       "max yaw rate (rad/s)", "scored (s)", "designed for"],
                      [[d.label, d.data["duration_s"], f"{d.data['frames']} ({d.data['dropped_frames']})",
                        "{:.3f}-{:.3f}".format(*d.data["dt_range"]), "{:.1f}-{:.1f}".format(*d.data["speed_range"]),
                        "{:+.2f} .. {:+.2f}".format(*d.data["ref_range_deg"]), d.data["yaw_rate_max"],
                        d.data["scored_s"], _design_cell(d.data.get("design", {}))] for d in v.drives],
                      digits={"duration (s)": 1, "scored (s)": 1}, align="lrrrrrrrl"))
    L.append("\nDesigned for: the car (without a vehicle file the shipped one that fits the drive, "
             "`roadbank.vehicle.design_car`) and whether the drive is quiet, with its `ay` noise floor over the "
             f"data sheet's density (`roadbank.vehicle.design_record`; quiet at most {QUIET_RATIO:g}: the default is "
             "then the car's model).")
    L.append("")
    L += excluded_lines(v)
    L += split_lines(v, h)
    for d in v.drives:
        L.append(f"{h}# {d.label}\n")
        _table(L, d.scores.items())
        if figures and d.label in figures:
            L.append(f"![{d.label}: theta vs INS roll]({figures[d.label]})\n")
    if any("suv" in d.sensitivity for d in v.drives):
        L.append(f"{h}# Sensitivity to the vehicle data\n")
        L.append("Raw theta RMS (deg) as run (no vehicle file: the car for a log whose car is not described, "
                 "the shipped `sedan`; KITTI's car is a VW Passat B6) and with the paper's SUV (`VehicleParams()`):\n")
        names = [n for n, s in v.drives[0].scores.items() if s.valid_fraction > 0]
        body = []
        for d in v.drives:
            suv = d.sensitivity.get("suv", {})
            body.append([d.label] + [f"{_f(d.scores[n].rms_raw_deg)} / {_f(suv[n].rms_raw_deg) if n in suv else 'n/a'}"
                                     for n in names])
        L.append(md_table(["drive"] + [f"{n} sedan / SUV" for n in names], body, align="l" + "r" * len(names)))
        L.append("")
    if any("R_nominal" in d.sensitivity for d in v.drives):
        L.append("Raw theta RMS (deg) of the sensor-weighted PIFs designed as above (the ESP sensors' "
                 "noise densities at the drive's 10 Hz, and the `ay` input's at least the road noise "
                 "measured on the drive's own `ay`: `roadbank.vehicle.log_conditions`), from the data sheet "
                 "alone at 10 Hz (no measured `ay` noise), and from the data sheet at the sensor's nominal "
                 "100 Hz (`R`, `Q_ay` ten times smaller, a faster filter; see the 10 Hz section for the "
                 "same comparison on the simulator):\n")
        names = list(next(d.sensitivity["R_nominal"] for d in v.drives if "R_nominal" in d.sensitivity))
        body = [[d.label] + [f"{_f(d.scores[n].rms_raw_deg)} / {_f(d.sensitivity['sheet_rate'][n].rms_raw_deg)}"
                             f" / {_f(d.sensitivity['R_nominal'][n].rms_raw_deg)}"
                             for n in names] for d in v.drives if "R_nominal" in d.sensitivity]
        L.append(md_table(["drive"] + [f"{n} as run / sheet 10 Hz / sheet 100 Hz" for n in names], body,
                          align="l" + "r" * len(names)))
        L.append("")
    L.append(f"{h}# Pooled over the drives\n")
    L.append("Every scored sample of every drive together (n samples).\n")
    L.append(md_table(["estimator", "rms raw (deg)", "r raw", "rms smoothed (deg)", "r smoothed", "n"],
                      [[name] + ([p["rms_raw_deg"], p["r_raw"], p["rms_deg"], p["r"]] if p["n"] else [None] * 4)
                       + [int(p["n"])] for name, p in v.pooled.items()],
                      digits=3, best=_BEST, best_in="column"))
    L.append("\nBest of each score column in bold (smallest RMS, largest r).\n")
    L += short_log_lines(v, h)
    L += smooth_road_lines(v, h)
    L += limits_lines(v, h)
    L.append(f"{h}# Method (KITTI)\n")
    L.append("- Reader: `roadbank.io.load_log(drive)` (format `kitti-oxts`, detected from the folder): "
             "columns 8 `vf` -> vx, 12 `ay` -> ay, 19 `wz` -> r, 3 `roll` -> reference, 0/1 lat/lon kept "
             "(`Log.extra`); already ISO 8855, no sign change; `delta_f` NaN. The frames keep their own "
             "time stamps (no resampling): the estimators integrate each step with trapezoidal substeps "
             "of at most 20 ms (see the 10 Hz section below).")
    L.append(f"- Scoring: the same code as comma2k19 (`roadbank.validation.scoring`): samples with vx >= "
             f"{st['v_gate']:g} m/s. {_warmup_text(st)} The split tables also give the RMS with a warm-up "
             "after each stop longer than 1 s. The estimate compared is `theta` (bank + body roll, what the "
             "INS roll measures).")
    L.append("- No offset is fitted on KITTI: the roll, `ay` and `wz` are outputs of one INS in one "
             "vehicle-aligned frame, so there is no mounting offset to remove, and a bias of an estimator "
             "must count. (comma2k19 fits one because its reference is the roll of a phone on the "
             "windshield.)")
    L.append(f"- Smoothing: the **raw** columns are the primary ones on KITTI (the INS outputs are clean; the "
             f"targets are judged on them). The smoothed columns apply the common zero-phase low-pass "
             f"(tau = {st['tau']:.3f} s) to the reference and the estimate: it removes noise without lag, so "
             "it favours a lag-free estimate (the kinematic one) over any causal observer; it is the "
             "primary score on comma2k19 only because the phone IMU's vibration hides the bank there.")
    L.append("- Estimators that read the steering angle (dfc, uio, pio-original, pif-original, kalman) have "
             "no valid sample on KITTI and are listed as n/a. Vehicle data: none given, so the rule for a car "
             "that is not described (the shipped `sedan`'s parameters, as `roadbank estimate` uses); "
             "the kinematic estimates do not use vehicle data, the modified-model observers only weakly "
             "(sensitivity table above).")
    L.append("- These drives are validation data: no estimator weight or setting was chosen from them.\n")
    return "\n".join(L) + "\n"
