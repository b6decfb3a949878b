"""Saving report figures: one layout pass must give what matplotlib's own
``savefig(bbox_inches="tight")`` gives (the truth here), in less work."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

from roadbank.report import figures  # noqa: E402


def _figure():
    """Two stacked panels with 'best' legends that must avoid dense lines (like the report's)."""
    t = np.linspace(0.0, 25.0, 2501)
    fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for k, ax in enumerate(axes):
        ax.plot(t, 10 * np.sin(t / (2 + k)), "k", lw=2, label="Reference")
        for j in range(4):
            ax.plot(t, 10 * np.sin(t / (2 + k)) + 0.5 * j + np.cos(3 * t + j), lw=1, label=f"Method {j}")
        ax.plot(t[:800], np.full(800, 9.0), lw=1, label="crowds the upper left")
        ax.set_ylabel("Estimated bank (deg)")
        ax.set_title(f"panel {k}")
        ax.legend(fontsize=7, ncol=3, loc="best")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("Time (s)")
    return fig


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    d = tmp_path_factory.mktemp("figs")
    fig = _figure()
    fig.savefig(d / "tight.png", dpi=figures.DPI, bbox_inches="tight")
    plt.close(fig)
    paths = figures._save(_figure(), d / "ours")
    return d, paths


def test_png_is_pixel_identical_to_bbox_tight(saved):
    d, paths = saved
    assert [p.suffix for p in paths] == [".png", ".svg"] and all(p.exists() for p in paths)
    ours, tight = mpimg.imread(d / "ours.png"), mpimg.imread(d / "tight.png")
    assert ours.shape == tight.shape
    assert np.array_equal(ours, tight)


def test_svg_same_box_within_a_point_and_no_date(saved, tmp_path):
    d, paths = saved
    fig = _figure()
    fig.savefig(tmp_path / "tight.svg", dpi=figures.DPI, bbox_inches="tight")
    plt.close(fig)

    def size(p):
        head = p.read_text()[:2000]
        return np.array([float(head.split(f'{k}="')[1].split("pt")[0]) for k in ("width", "height")])
    assert np.allclose(size(d / "ours.svg"), size(tmp_path / "tight.svg"), atol=1.0)
    assert "<dc:date>" not in (d / "ours.svg").read_text()
