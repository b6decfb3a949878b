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

from .labels import CONDITION_LABELS, PAPER_SET, label  # noqa: E402

ROBUSTNESS_CONDITIONS = ("cf50", "nominal", "cf150")


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


def scenario_figure(scenario: str, cells: dict, path: Path, names=PAPER_SET) -> list[Path]:
    """Driver inputs (first condition) and one panel per condition with each method's bank estimate.

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
    ax.legend(fontsize=7, loc="best")
    ax.grid(alpha=0.3)
    for ax, cond in zip(axes[1:], conds):
        cell = cells[cond]
        ax.plot(cell.t, np.rad2deg(cell.reference), "k", lw=2, label="Reference")
        for name in names:
            if name in cell.phi_b:
                ax.plot(cell.t, np.rad2deg(cell.phi_b[name]), lw=1, label=f"{label(name)} Method")
        lo, hi = np.nanpercentile(np.rad2deg(cell.reference), [0, 100])
        ax.set_ylim(min(lo, 0) - 10, max(hi, 0) + 10)
        ax.set_ylabel("Estimated bank (deg)")
        ax.set_title(f"{scenario}: {CONDITION_LABELS.get(cond, cond)}")
        ax.legend(fontsize=7, ncol=3, loc="best")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("Time (s)")
    return _save(fig, path)


def robustness_figure(scenario: str, cells: dict, path: Path) -> list[Path] | None:
    """PIF on the modified vs the original model at 50/100/150 % plant Cf (paper Fig 4d-e, 7c-d)."""
    conds = [c for c in ROBUSTNESS_CONDITIONS if c in cells]
    if len(conds) < 2:
        return None
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.6), sharey=True)
    ref = cells[conds[0]]
    for ax, name in zip(axes, ("pif-modified", "pif-original")):
        ax.plot(ref.t, np.rad2deg(ref.reference), "k", lw=2, label="Reference")
        for cond in conds:
            cell = cells[cond]
            if name in cell.phi_b:
                pct = {"cf50": "50% Cf", "nominal": "100% Cf", "cf150": "150% Cf"}[cond]
                ax.plot(cell.t, np.rad2deg(cell.phi_b[name]), lw=1, label=pct)
        lo, hi = np.nanpercentile(np.rad2deg(ref.reference), [0, 100])
        ax.set_ylim(min(lo, 0) - 15, max(hi, 0) + 15)
        ax.set_title(f"{scenario}: {label(name)}")
        ax.set_xlabel("Time (s)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("Estimated bank (deg)")
    return _save(fig, path)
