"""Tables, JSON and figures of the KITTI validation (a section of docs/real-data.md)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .kitti import KittiValidation

#: issue 14 targets for the default PIF on KITTI (theta vs INS roll, raw, vx > 5 m/s)
TARGET_RMS_DEG = 0.5


def _f(x, nd=3):
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{nd}f}"


def _j(x):
    return None if isinstance(x, float) and math.isnan(x) else round(float(x), 4)


def to_json(v: KittiValidation) -> dict:
    """``{"drives": {drive: {estimator: {...}}}, "pooled": {estimator: {...}}, "errors": [...]}``.

    Per estimator: ``r``, ``rms_deg`` (smoothed), ``r_raw``, ``rms_raw_deg`` (unsmoothed),
    ``offset_deg`` (0: not fitted on KITTI); null where the estimator has no valid sample.
    """
    drives = {d.label: {n: {"r": _j(s.r), "rms_deg": _j(s.rms_deg), "r_raw": _j(s.r_raw),
                            "rms_raw_deg": _j(s.rms_raw_deg), "offset_deg": _j(s.offset_deg)}
                        for n, s in d.scores.items()} for d in v.drives}
    pool = {n: {k: (_j(x) if k != "n" else x) for k, x in p.items()} for n, p in v.pooled.items()}
    return {"drives": drives, "pooled": pool, "errors": list(v.errors)}


def plot_drive(res, path, show=("kinematic", "pio-modified", "pif-modified")) -> None:
    """Raw theta of some estimators and the INS roll (deg) against time; unscored spans shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run = res.run
    t = res.t - res.t[0]
    fig, ax = plt.subplots(figsize=(9, 3.6))
    ax.plot(t, np.degrees(run.raw_reference), "k", lw=1.8, label="INS roll (reference)")
    for name in show:
        if name in run.raw_estimates and res.scores[name].valid_fraction > 0:
            ax.plot(t, np.degrees(run.raw_estimates[name]), lw=1.0, label=f"{name} theta")
    off = ~run.scored
    edges = np.flatnonzero(np.diff(np.r_[0, off.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        ax.axvspan(t[a], t[min(b, len(t) - 1)], color="grey", alpha=0.15, lw=0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("roll (deg)")
    ax.legend(fontsize=8, ncol=2)
    ax.grid(alpha=0.3)
    ax.set_title(f"KITTI {res.label}: theta vs INS roll (grey: not scored, vx < 5 m/s or warm-up)", fontsize=9)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _table(L, rows):
    L.append("| estimator | rms raw (deg) | r raw | rms smoothed (deg) | r smoothed | r causal LP | "
             "lag for max r (s) | valid |")
    L.append("|---|---|---|---|---|---|---|---|")
    for name, s in rows:
        if s.valid_fraction == 0:
            L.append(f"| {name} | n/a | n/a | n/a | n/a | n/a | n/a | 0.00 (needs the steering angle) |")
            continue
        L.append(f"| {name} | **{_f(s.rms_raw_deg)}** | {_f(s.r_raw)} | {_f(s.rms_deg)} | {_f(s.r)} | "
                 f"{_f(s.r_causal)} | {s.best_lag_s:+.2f} | {s.valid_fraction:.2f} |")
    L.append("")


def target_lines(v: KittiValidation) -> list[str]:
    """The issue-14 targets checked per drive for the default PIF (raw RMS, and smoothed for reference)."""
    L = []
    for d in v.drives:
        pif, kin = d.scores.get("pif-modified"), d.scores.get("kinematic")
        if pif is None or kin is None:
            continue
        ok1 = pif.rms_raw_deg <= TARGET_RMS_DEG
        ok2 = pif.rms_raw_deg < kin.rms_raw_deg
        L.append(f"| {d.label} | {_f(pif.rms_raw_deg)} | {_f(kin.rms_raw_deg)} | {'met' if ok1 else 'NOT met'} | "
                 f"{'met' if ok2 else 'NOT met'} | {_f(pif.rms_deg)} | {_f(kin.rms_deg)} |")
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
    L.append("| drive | duration (s) | frames (dropped) | step (s) | speed (m/s) | roll (deg) | max yaw rate (rad/s) | scored (s) |")
    L.append("|---|---|---|---|---|---|---|---|")
    for d in v.drives:
        x = d.data
        L.append(f"| {d.label} | {x['duration_s']:.1f} | {x['frames']} ({x['dropped_frames']}) | "
                 f"{x['dt_range'][0]:.3f}-{x['dt_range'][1]:.3f} | {x['speed_range'][0]:.1f}-{x['speed_range'][1]:.1f} | "
                 f"{x['ref_range_deg'][0]:+.2f} .. {x['ref_range_deg'][1]:+.2f} | {x['yaw_rate_max']:.2f} | "
                 f"{x['scored_s']:.1f} |")
    L.append("")
    for e in v.errors:
        L.append(f"- not read: {e}")
    if v.errors:
        L.append("")
    L.append(f"{h}# Targets (issue 14: default `pif-modified`, raw theta RMS vs INS roll at vx > 5 m/s)\n")
    L.append(f"| drive | PIF rms raw (deg) | kinematic rms raw (deg) | PIF <= {TARGET_RMS_DEG} deg | PIF < kinematic | "
             "PIF rms smoothed | kinematic rms smoothed |")
    L.append("|---|---|---|---|---|---|---|")
    L += target_lines(v)
    L.append("")
    for d in v.drives:
        L.append(f"{h}# {d.label}\n")
        _table(L, d.scores.items())
        if figures and d.label in figures:
            L.append(f"![{d.label}: theta vs INS roll]({figures[d.label]})\n")
    L.append(f"{h}# Pooled over the drives\n")
    L.append("Every scored sample of every drive together (n samples).\n")
    L.append("| estimator | rms raw (deg) | r raw | rms smoothed (deg) | r smoothed | n |")
    L.append("|---|---|---|---|---|---|")
    for name, p in v.pooled.items():
        if p["n"] == 0:
            L.append(f"| {name} | n/a | n/a | n/a | n/a | 0 |")
        else:
            L.append(f"| {name} | **{_f(p['rms_raw_deg'])}** | {_f(p['r_raw'])} | {_f(p['rms_deg'])} | "
                     f"{_f(p['r'])} | {p['n']} |")
    L.append("")
    L.append(f"{h}# Method (KITTI)\n")
    L.append(f"- Reader: `roadbank.io.load_log(drive)` (format `kitti-oxts`, detected from the folder): "
             "columns 8 `vf` -> vx, 12 `ay` -> ay, 19 `wz` -> r, 3 `roll` -> reference, 0/1 lat/lon kept "
             "(`Log.extra`); already ISO 8855, no sign change; `delta_f` NaN. The frames keep their own "
             "time stamps (no resampling): the estimators integrate each step with trapezoidal substeps "
             "of at most 20 ms (see the 10 Hz section below).")
    L.append(f"- Scoring: the same code as comma2k19 (`roadbank.validation.scoring`): samples with vx >= "
             f"{st['v_gate']:g} m/s; {st['warmup_s']:g} s warm-up after each start (first sample above the gate, "
             "or after more than 1 s below it: the estimators re-initialise then); the estimate compared is "
             "`theta` (bank + body roll, what the INS roll measures).")
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
             "no valid sample on KITTI and are listed as n/a. Vehicle data: `SEDAN` (KITTI's VW Passat B6 "
             "has the same 2.71 m wheelbase class); the modified-model observers' `theta` does not use "
             "the vehicle data.")
    L.append("- These drives are validation data: no estimator weight or setting was chosen from them.\n")
    return "\n".join(L) + "\n"
