"""Time plots of estimates on one log: reference, error panel, flagged spans (``estimate --plot``,
``validate``).

Angles are drawn in degrees, time in seconds from the log start; samples an
estimator flagged not valid are left out of its line and shaded. Uses the
non-interactive Agg backend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["flagged_spans", "shade_flagged", "estimate_figure", "plot_estimates", "reference_figure",
           "save_figure"]

FLAG_STYLE = {"color": "tab:red", "alpha": 0.12, "lw": 0}
FLAG_LABEL = "flagged not valid"


def flagged_spans(t, valid) -> list[tuple[float, float]]:
    """Time spans (s) of consecutive samples flagged not valid.

    Each span runs from the first flagged sample to the next valid sample (the last
    sample's time if the log ends flagged), so a single flagged sample covers one
    sample interval.

    Parameters
    ----------
    t : array (s), increasing
    valid : bool array, same length
    """
    t = np.asarray(t, dtype=float)
    bad = ~np.asarray(valid, dtype=bool)
    if len(t) != len(bad):
        raise ValueError(f"flagged_spans: {len(t)} times but {len(bad)} valid flags")
    edges = np.flatnonzero(np.diff(np.r_[0, bad.astype(np.int8), 0]))
    spans = []
    for i0, i1 in zip(edges[::2], edges[1::2]):       # flagged samples i0 .. i1-1
        spans.append((float(t[i0]), float(t[min(i1, len(t) - 1)])))
    return spans


def shade_flagged(axes, t, valid, t0: float = 0.0, label: str | None = FLAG_LABEL) -> int:
    """Shade every flagged span (:func:`flagged_spans`) on each of ``axes``; times shifted by ``-t0`` (s).

    The legend label goes on the first span of the first axis only. Returns the number of spans.
    """
    spans = flagged_spans(t, valid)
    for k, ax in enumerate(np.atleast_1d(axes)):
        for j, (a, b) in enumerate(spans):
            ax.axvspan(a - t0, b - t0, label=label if (j == 0 and k == 0) else None, **FLAG_STYLE)
    return len(spans)


def _deg(x):
    return np.degrees(np.asarray(x, dtype=float))


def estimate_figure(t, estimates, *, reference_roll=None, truth: dict | None = None, title: str = ""):
    """theta, phi_b and their error (deg) against time from the log start (s).

    Parameters
    ----------
    t : array (s)
        The log's time base (``Signals.t``).
    estimates : sequence of :class:`roadbank.estimators.base.Estimate`
        On ``t``; ``name``, ``theta``, ``phi_b`` (rad), ``valid``.
    reference_roll : array (rad), optional
        A reference roll angle of the log (e.g. INS roll: bank + body roll + mounting offset),
        drawn in the theta panel; the error panel shows ``theta - reference_roll`` when there
        is no bank truth.
    truth : dict, optional
        Truth columns of a simulated log (``true_phi_b``, ``true_theta``; rad on ``t``). With
        ``true_phi_b`` the error panel shows ``phi_b - true_phi_b``.
    title : str
        Figure title (e.g. the log's path).

    Returns
    -------
    matplotlib.figure.Figure
        Two panels (theta, phi_b), plus an error panel when a reference or truth is given.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.asarray(t, dtype=float)
    truth = truth or {}
    true_bank, true_theta = truth.get("true_phi_b"), truth.get("true_theta")
    if true_bank is not None:
        err_of, err_ref, err_label = "phi_b", true_bank, "bank error phi_b - true (deg)"
    elif reference_roll is not None:
        err_of, err_ref, err_label = "theta", reference_roll, "theta - reference roll (deg)"
    else:
        err_of = None
    n = 3 if err_of else 2
    fig, axes = plt.subplots(n, 1, sharex=True, figsize=(9, 2.4 * n + 1.0))
    tt = t - t[0]
    flagged = np.zeros(len(t), bool)
    for est in estimates:
        valid = np.asarray(est.valid, bool)
        flagged |= ~valid
        axes[0].plot(tt, np.where(valid, _deg(est.theta), np.nan), lw=0.9, label=est.name)
        axes[1].plot(tt, np.where(valid, _deg(est.phi_b), np.nan), lw=0.9, label=est.name)
        if err_of:
            e = _deg(getattr(est, err_of)) - _deg(err_ref)
            axes[2].plot(tt, np.where(valid, e, np.nan), lw=0.9, label=est.name)
    if true_theta is not None:
        axes[0].plot(tt, _deg(true_theta), "k", lw=1.6, alpha=0.7, label="true theta", zorder=3)
    if reference_roll is not None:
        axes[0].plot(tt, _deg(reference_roll), "k--", lw=1.4, label="reference roll", zorder=3)
    if true_bank is not None:
        axes[1].plot(tt, _deg(true_bank), "k", lw=1.6, alpha=0.7, label="true bank", zorder=3)
    if err_of:
        axes[2].axhline(0.0, color="k", lw=0.6)
        axes[2].set_ylabel(err_label)
    shade_flagged(axes, t, ~flagged, t0=t[0])
    axes[0].set_ylabel("theta = bank + roll (deg)")
    axes[1].set_ylabel("road bank phi_b (deg)")
    axes[-1].set_xlabel("time from log start (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=4, loc="best")
    if title:
        axes[0].set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def reference_figure(t, reference, estimates: dict, *, valid: dict | None = None, unscored=None,
                     split_time: float | None = None, quantity: str = "roll",
                     reference_label: str = "reference", title: str = ""):
    """Estimates against a reference (deg) and their error, against time from the log start (s).

    Parameters
    ----------
    t : array (s)
    reference : array (rad)
        The reference angle on ``t`` (e.g. the INS or pose roll).
    estimates : dict label -> array (rad)
        Estimates comparable with the reference, on ``t``.
    valid : dict label -> bool array, optional
        The estimators' valid flags (same keys as ``estimates``): each line leaves out its
        flagged samples, and spans where any is False are shaded red.
    unscored : bool array, optional
        Samples left out of the scores (warm-up, below the speed gate), shaded grey.
    split_time : float (s, same clock as ``t``), optional
        End of the offset-fit part (dotted line); scored after it.
    quantity, reference_label, title : str
        Panel label (``"<quantity> (deg)"``), legend entry of the reference, figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels: the angles, and estimate - reference.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.asarray(t, dtype=float)
    tt = t - t[0]
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(9, 5.6), gridspec_kw={"height_ratios": [3, 2]})
    axes[0].plot(tt, _deg(reference), "k", lw=1.8, label=reference_label, zorder=3)
    for name, x in estimates.items():
        x = _deg(x)
        if valid and name in valid:
            x = np.where(valid[name], x, np.nan)
        axes[0].plot(tt, x, lw=1.0, label=name)
        axes[1].plot(tt, x - _deg(reference), lw=1.0, label=name)
    axes[1].axhline(0.0, color="k", lw=0.6)
    if unscored is not None:
        for k, (a, b) in enumerate(flagged_spans(t, ~np.asarray(unscored, bool))):
            for j, ax in enumerate(axes):
                ax.axvspan(a - t[0], b - t[0], color="grey", alpha=0.15, lw=0,
                           label="not scored" if (k == 0 and j == 0) else None)
    if valid:
        ok = np.logical_and.reduce([np.asarray(v, bool) for v in valid.values()])
        shade_flagged(axes, t, ok, t0=t[0])
    if split_time is not None:
        for j, ax in enumerate(axes):
            ax.axvline(split_time - t[0], color="grey", ls=":", lw=1.2,
                       label="offset fitted before, scored after" if j == 0 else None)
    axes[0].set_ylabel(f"{quantity} (deg)")
    axes[1].set_ylabel("estimate - reference (deg)")
    axes[1].set_xlabel("time from log start (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=3, loc="best")
    if title:
        axes[0].set_title(title, fontsize=9)
    fig.tight_layout()
    return fig


def save_figure(fig, path):
    """Save ``fig`` to ``path`` (format from the suffix; folders created) and close it; ``path`` may
    also be a binary file object (a PNG is written to it). Returns ``path``."""
    import matplotlib.pyplot as plt

    if hasattr(path, "write"):
        fig.savefig(path, format="png", dpi=110)
    else:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_estimates(path, t, estimates, reference_roll=None, title: str = "", truth: dict | None = None) -> Path:
    """:func:`estimate_figure` saved to ``path`` (PNG, SVG or PDF by suffix)."""
    return save_figure(estimate_figure(t, estimates, reference_roll=reference_roll, truth=truth, title=title),
                       path)
