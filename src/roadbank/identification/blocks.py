"""Blocks of samples and the block bootstrap used for every uncertainty of the identification.

The residuals of the regressions are correlated over a few tenths of a second
(vehicle response, low-pass filtering), so resampling single samples would
understate the uncertainty. The data are cut into blocks of contiguous samples
(default 5 s, much longer than that correlation) and whole blocks are resampled
with replacement (a block bootstrap). Each block is summarised by sufficient
statistics, so a replicate costs one small linear solve.
"""

from __future__ import annotations

import numpy as np

from .prepare import runs


def chop(mask: np.ndarray, block_len: int, min_len: int) -> list[tuple[int, int]]:
    """Cut the True stretches of ``mask`` into blocks of about ``block_len`` samples.

    Stretches shorter than ``min_len`` are dropped; a stretch is split into
    ``round(len / block_len)`` (at least one) blocks of equal length.
    """
    out: list[tuple[int, int]] = []
    for a, b in runs(mask, min_len):
        k = max(1, int(round((b - a) / block_len)))
        edges = np.linspace(a, b, k + 1).round().astype(int)
        out.extend((int(edges[i]), int(edges[i + 1])) for i in range(k))
    return out


def normal_equations(X: np.ndarray, y: np.ndarray, spans: list[tuple[int, int]]):
    """Per-block ``X^T X`` (k, p, p), ``X^T y`` (k, p) and sample counts (k,) of the rows in ``spans``."""
    p = X.shape[1]
    XtX = np.zeros((len(spans), p, p))
    Xty = np.zeros((len(spans), p))
    n = np.zeros(len(spans))
    for i, (a, b) in enumerate(spans):
        Xb, yb = X[a:b], y[a:b]
        XtX[i], Xty[i], n[i] = Xb.T @ Xb, Xb.T @ yb, b - a
    return XtX, Xty, n


def solve(XtX: np.ndarray, Xty: np.ndarray) -> np.ndarray:
    """Least-squares coefficients from summed normal equations (minimum norm if singular)."""
    return np.linalg.lstsq(XtX, Xty, rcond=1e-12)[0]


def bootstrap(XtX: np.ndarray, Xty: np.ndarray, n_boot: int, seed: int) -> np.ndarray:
    """Block-bootstrap replicates (n_boot, p) of the least-squares coefficients."""
    k = len(XtX)
    rng = np.random.default_rng(seed)
    counts = rng.multinomial(k, np.full(k, 1.0 / k), size=n_boot)  # how often each block is drawn
    A = np.einsum("bk,kij->bij", counts, XtX)
    c = np.einsum("bk,ki->bi", counts, Xty)
    return np.stack([solve(A[i], c[i]) for i in range(n_boot)])


def robust_std(x: np.ndarray) -> float:
    """Standard deviation from the 16th-84th percentile range (one sigma for a normal law),
    insensitive to the few wild replicates a ratio of estimates can produce."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    if len(x) < 2:
        return float("nan")
    lo, hi = np.percentile(x, [15.865, 84.135])
    return float(0.5 * (hi - lo))
