"""The robustness table: every estimator through every fault, against a clean run.

Base log: a simulated scenario (default ``bank-lane-change``, nominal condition,
seed 0: its signals vary, so a stuck sensor is visible — on ``const-bank`` every
channel is constant and a stuck sensor changes nothing). Each fault acts on the
window ``[T0, T0 + length)`` (1 s, or the gap length for dropouts of 0.05, 0.5
and 2 s); ``T0 = 8.5 s`` is the start of the lane change from the banked lane
back to the flat one. For each fault x estimator:

``flagged_pct``
    Samples of the fault window flagged not valid (%).
``max_err_deg`` / ``clean_max_err_deg``
    Max |phi_b - true bank| (deg) over the valid samples after the 2 s settling
    time, faulty and clean log: how much garbage escapes the flag.
``max_dev_deg``
    Max |phi_b - phi_b of the clean run| (deg) over the valid samples: the part
    of the error the fault causes.
``recovery_s``
    Re-convergence time after the fault ends (s): from ``T0 + length`` to the
    first sample after which the faulty run stays within 0.5 deg of the clean
    run of the same estimator for the rest of the log (0 = never left the band,
    NaN = did not re-converge before the end).
``nonfinite``
    Any non-finite ``w, theta, phi_b`` output (must be False).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import estimators as E
from ..report.markdown import Markdown, md_table
from .inject import FAULTS, Stream, apply, feed

T0 = 8.5                #: start of every fault window (s)
SCENARIO = "bank-lane-change"  #: default base scenario
LENGTH = 1.0            #: fault window length (s) except dropouts
BAND_DEG = 0.5          #: re-convergence band around the clean run (deg)
SETTLE = 2.0            #: seconds excluded from the error at the start
DROPOUTS = (0.05, 0.5, 2.0)


@dataclass(frozen=True)
class Case:
    """One row label of the table: a fault name and its window length (s)."""

    fault: str
    length: float

    @property
    def label(self) -> str:
        return f"{self.fault} {self.length:g} s" if self.fault == "dropout" else self.fault


def cases() -> list[Case]:
    """The fault cases of the table (dropouts at three gap lengths)."""
    out = []
    for name in FAULTS:
        if name == "dropout":
            out += [Case(name, g) for g in DROPOUTS]
        else:
            out.append(Case(name, LENGTH))
    return out


def recovery_time(t, a, b, t_end: float, band: float) -> float:
    """Seconds after ``t_end`` until ``|a - b| <= band`` holds for good (0 if it never left,
    NaN if it is outside the band at the last sample)."""
    out = np.abs(a - b) > band
    if out[-1]:
        return float("nan")
    if not out.any():
        return 0.0
    last = int(np.flatnonzero(out)[-1])
    return max(0.0, float(t[last + 1] - t_end))


def fault_rows(base_stream: Stream, truth_t, truth_bank, names=E.NAMES, seed: int = 0) -> list[dict]:
    """The table rows (dicts) for ``base_stream`` with the bank truth ``truth_bank`` (rad) at ``truth_t``."""
    rows = []
    clean = {n: feed(E.make(n), base_stream) for n in names}
    for case in cases():
        t1 = T0 + case.length
        fs = apply(base_stream, case.fault, T0, t1, seed)
        if len(fs) == len(base_stream):   # same samples: the window is where they were
            win = (base_stream.t >= T0) & (base_stream.t < t1)
        else:
            win = (fs.t >= T0) & (fs.t < t1)
        for n in names:
            est = E.make(n)
            e = feed(est, fs)
            c = clean[n]
            finite = bool(np.all(np.isfinite(e.w)) and np.all(np.isfinite(e.theta)) and np.all(np.isfinite(e.phi_b)))
            truth = np.interp(e.t, truth_t, truth_bank)
            scored = e.valid & (e.t >= base_stream.t[0] + SETTLE)
            err = np.degrees(np.abs(e.phi_b - truth))
            cerr = np.degrees(np.abs(c.phi_b - np.interp(c.t, truth_t, truth_bank)))
            cscored = c.valid & (c.t >= base_stream.t[0] + SETTLE)
            after = e.t >= t1
            ref = np.interp(e.t[after], c.t, c.phi_b)
            rec = recovery_time(e.t[after], np.degrees(e.phi_b[after]), np.degrees(ref), t1, BAND_DEG) \
                if after.any() else float("nan")
            ok = e.valid & (e.t >= base_stream.t[0] + SETTLE)
            dev = np.degrees(np.abs(e.phi_b[ok] - np.interp(e.t[ok], c.t, c.phi_b)))
            rows.append({"fault": case.label, "estimator": n,
                         "flagged_pct": 100.0 * float(np.mean(~e.valid[win])) if win.any() else 0.0,
                         "max_err_deg": float(np.max(err[scored])) if scored.any() else float("nan"),
                         "clean_max_err_deg": float(np.max(cerr[cscored])),
                         "max_dev_deg": float(np.max(dev)) if len(dev) else float("nan"),
                         "recovery_s": rec, "nonfinite": not finite})
    return rows


def robustness_rows(scenario: str = SCENARIO, seed: int = 0, names=E.NAMES) -> list[dict]:
    """Simulate ``scenario`` (nominal) and return :func:`fault_rows` for it."""
    from ..sim import run_scenario

    sim = run_scenario(scenario, seed=seed)
    return fault_rows(Stream.from_signals(sim.signals), sim.truth.t, sim.truth.phi_b, names, seed)


def _cell(r: dict) -> Markdown:
    rec = "never" if math.isnan(r["recovery_s"]) else f"{r['recovery_s']:.2f}"
    bad = " **NON-FINITE**" if r["nonfinite"] else ""
    return Markdown(f"{r['flagged_pct']:.0f} / {r['max_err_deg']:.1f} / {r['max_dev_deg']:.1f} / {rec}{bad}")


def _table(rows: list[dict], names: list, faults: list, by: dict) -> str:
    """The fault x estimator table (composite cells right-aligned) and the clean run's max error."""
    body = [[f] + [_cell(by[(f, n)]) for n in names] for f in faults]
    clean = {n: next(r["clean_max_err_deg"] for r in rows if r["estimator"] == n) for n in names}
    body.append([Markdown("*clean run: max err*")] + [clean[n] for n in names])
    return md_table(["fault"] + names, body, digits=1, align="l" + "r" * len(names))


def markdown(rows: list[dict], scenario: str, command: str) -> str:  # noqa: C901
    """docs/robustness.md: the description, the wide table and the clean-run reference errors."""
    names = list(dict.fromkeys(r["estimator"] for r in rows))
    faults = list(dict.fromkeys(r["fault"] for r in rows))
    by = {(r["fault"], r["estimator"]): r for r in rows}
    nonfinite = [f"{r['fault']} / {r['estimator']}" for r in rows if r["nonfinite"]]
    lines = [
        "# Robustness: what each estimator does through each fault", "",
        f"Generated by `{command}` (module `roadbank.faults.table`). Base log: the simulated "
        f"`{scenario}` scenario (nominal, seed 0, 100 Hz). Every fault acts on the window starting at "
        f"t = {T0:g} s, {LENGTH:g} s long (dropouts: the gap length); the signals are clean again "
        "after it. Faults are in `roadbank.faults.inject.FAULTS`; logs with repeated or decreasing "
        "time stamps (which `Signals` refuses) are fed through streaming `step()` (for the offline "
        "`pif-smoother` that is its causal forward filter, so on those two logs it is the filter "
        "that is compared with the smoothed clean run).", "",
        "Each cell: **flagged % / max err / max dev / recovery**:", "",
        "- *flagged %*: samples of the fault window flagged `valid=False` (outputs held);",
        f"- *max err*: max |phi_b - true bank| (deg) over the valid samples after {SETTLE:g} s — what "
        "escapes the flag (compare with the clean run's row at the bottom: the lane changes "
        "themselves cost the model-based estimators several degrees);",
        "- *max dev*: max |phi_b - phi_b of the clean run| (deg) over the valid samples — the error "
        "the fault adds;",
        f"- *recovery*: seconds after the fault ends until the output stays within {BAND_DEG:g} deg of "
        "the clean run of the same estimator (0 = never left the band; never = still outside at the end).",
        "", "Non-finite outputs: " + (", ".join(nonfinite) if nonfinite else "**none** in any cell."), "",
        _table(rows, names, faults, by)]
    lines += ["", "## Reading the table", "",
              "- Bad samples (NaN/inf), repeated and decreasing time stamps, and speeds below v_min "
              "(5 m/s, including reversing) are flagged and the output is held; the state is not "
              "updated by them, so these faults cost (almost) no accuracy.",
              "- Dropouts are not flagged (no samples arrive); a gap longer than max_gap (1 s) "
              "re-initialises the estimators, which then re-converge from scratch.",
              "- An estimate with |w| = |sin(theta)| > 1 has no angle: it is flagged `valid=False` "
              "(the UIO and the original-model PIF get there under extreme steering; they used to "
              "report it valid, found with this table, tests/test_faults.py "
              "`test_impossible_w_is_flagged_not_valid`), so their flagged % there is not 0.",
              "- Stuck sensors, bias steps, saturation and an impossible steering angle are *plausible* "
              "values: nothing in a single sample flags them, so they show as error (max err) and as "
              "recovery time. Detecting them needs cross-channel plausibility checks (see below).",
              "- Wrong units (speed in km/h, angles in degrees) are caught at the readers "
              "(`roadbank.io`, `check_plausible` and the cross-channel check "
              "`check_consistency`), not by the estimators; see docs/io.md.", ""]
    return "\n".join(lines)
