"""Figures like the paper's (Fig 2, 3, 4, 6, 7): driver inputs, estimates per condition,
and the Cf-robustness panels of the PIF on the modified vs the original model.

Angles are plotted in degrees; every function writes PNG and SVG and returns the
paths. Uses the non-interactive Agg backend.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..defaults import ESTIMATOR as DEFAULT_ESTIMATOR  # noqa: E402
from .labels import CONDITION_LABELS, PAPER_SET, label  # noqa: E402

ROBUSTNESS_CONDITIONS = ("cf50", "nominal", "cf150")
#: the estimators a scenario figure draws by default (those the study has): the paper's
#: methods, the Kalman peer, roadbank's default PIF, the variants the tables favour and the
#: estimator the commands run when none is named
FIGURE_SET = PAPER_SET + ("pif-rate", "pif-gated", "pif-smoother", DEFAULT_ESTIMATOR)
#: the reference line: black, drawn over the estimates so that a noisy estimate cannot hide it
REFERENCE_STYLE = {"color": "k", "lw": 1.6, "alpha": 0.85, "zorder": 10}


def _legend_outside(ax) -> None:
    """The axis legend to the right of the axes, one entry per line: it never covers a curve."""
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, frameon=False)


DPI = 110


def _freeze_best_legends(fig, renderer) -> None:
    """Pin every ``loc="best"`` legend where it was just placed (fraction of its anchor box),
    so later draws do not search the lines again; the position is dpi independent."""
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None or leg._loc != 0:       # 0: "best" (matplotlib's code)
            continue
        box = leg.get_window_extent(renderer)
        anchor = leg.get_bbox_to_anchor()
        leg.set_loc(((box.x0 - anchor.x0) / anchor.width, (box.y0 - anchor.y0) / anchor.height))


def _save(fig, path: Path) -> list[Path]:
    """Write ``path`` as PNG and SVG, cropped to the drawn content (like ``bbox_inches="tight"``).

    One layout pass (the tight box, which also places ``"best"`` legends) serves both files:
    ``savefig(bbox_inches="tight")`` lays the figure out twice per format (draw, then the
    tight box) before drawing it, and a ``"best"`` legend searches every line each time.
    The PNG is pixel-identical to the ``"tight"`` one; the SVG box agrees within a point
    (it was measured with the SVG renderer). SVGs carry no date (reproducible files).
    """
    fig.set_dpi(DPI)
    renderer = fig.canvas.get_renderer()
    bbox = fig.get_tightbbox(renderer).padded(matplotlib.rcParams["savefig.pad_inches"])
    _freeze_best_legends(fig, renderer)
    out = []
    for ext, meta in ((".png", None), (".svg", {"Date": None})):
        p = path.with_suffix(ext)
        fig.savefig(p, dpi=DPI, bbox_inches=bbox, metadata=meta)
        out.append(p)
    plt.close(fig)
    return out


def scenario_figure(scenario: str, cells: dict, path: Path, names=FIGURE_SET) -> list[Path]:
    """Driver inputs (first condition) and one panel per condition with the bank estimate (deg)
    of each estimator of ``names`` that the cells have, the reference drawn over them.

    ``cells`` maps condition -> :class:`roadbank.report.reproduce.CellResult`.
    """
    conds = list(cells)
    first = cells[conds[0]]
    fig, axes = plt.subplots(1 + len(conds), 1, figsize=(8, 2.6 * (1 + len(conds))), sharex=True)
    ax = axes[0]
    t = first.t
    ax.plot(t, np.rad2deg(first.inputs["steering_wheel_angle"]), label="Steering wheel angle (deg)")
    ax.plot(t, first.inputs["vx"] * 3.6, label="Speed (km/h)")
    ax.plot(t, 100 * first.inputs["throttle"], label="Throttle (%)")
    ax.set_ylabel("Driver inputs (deg, km/h, %)")
    ax.set_title(f"{scenario}: driver inputs ({conds[0]})")
    _legend_outside(ax)
    ax.grid(alpha=0.3)
    for ax, cond in zip(axes[1:], conds):
        cell = cells[cond]
        for name in names:
            if name in cell.phi_b:
                text = label(name) if label(name) == name else f"{label(name)} ({name})"
                ax.plot(cell.t, np.rad2deg(cell.phi_b[name]), lw=1, label=text)
        ax.plot(cell.t, np.rad2deg(cell.reference), label="Reference (true bank)", **REFERENCE_STYLE)
        lo, hi = np.nanpercentile(np.rad2deg(cell.reference), [0, 100])
        ax.set_ylim(min(lo, 0) - 10, max(hi, 0) + 10)
        ax.set_ylabel("Estimated bank (deg)")
        ax.set_title(f"{scenario}: {CONDITION_LABELS.get(cond, cond)}")
        ax.grid(alpha=0.3)
    _legend_outside(axes[1])          # the same lines in every condition's panel: one legend
    axes[-1].set_xlabel("Time (s)")
    return _save(fig, path)


def robustness_figure(scenario: str, cells: dict, path: Path) -> list[Path] | None:
    """The PIF on the modified (``pif-paper``) vs the original model, both with Table 4, at
    50/100/150 % plant Cf (paper Fig 4d-e, 7c-d); None when the cells have neither."""
    conds = [c for c in ROBUSTNESS_CONDITIONS if c in cells]
    pifs = [n for n in ("pif-paper", "pif-original") if any(n in cells[c].phi_b for c in conds)]
    if len(conds) < 2 or not pifs:
        return None
    fig, axes = plt.subplots(1, len(pifs), figsize=(5.5 * len(pifs) + 1.5, 3.6), sharey=True, squeeze=False)
    axes = axes[0]
    ref = cells[conds[0]]
    for ax, name in zip(axes, pifs):
        for cond in conds:
            cell = cells[cond]
            if name in cell.phi_b:
                pct = {"cf50": "50% Cf", "nominal": "100% Cf", "cf150": "150% Cf"}[cond]
                ax.plot(cell.t, np.rad2deg(cell.phi_b[name]), lw=1, label=pct)
        ax.plot(ref.t, np.rad2deg(ref.reference), label="Reference", **REFERENCE_STYLE)
        lo, hi = np.nanpercentile(np.rad2deg(ref.reference), [0, 100])
        ax.set_ylim(min(lo, 0) - 15, max(hi, 0) + 15)
        ax.set_title(f"{scenario}: {label(name)}")
        ax.set_xlabel("Time (s)")
        ax.grid(alpha=0.3)
    _legend_outside(axes[-1])
    axes[0].set_ylabel("Estimated bank (deg)")
    return _save(fig, path)
