"""The reproduction report as a reader uses it: a linked contents list, one accuracy-aims table,
figures whose reference is drawn over the estimates, legends beside the axes, and the estimators
that ``--estimators`` chose."""

from __future__ import annotations

import html5lib
import matplotlib
import numpy as np
import pytest
from click.testing import CliRunner

matplotlib.use("Agg")

from roadbank.cli import main  # noqa: E402
from roadbank.report import figures  # noqa: E402
from roadbank.report.reproduce import CellResult  # noqa: E402

NS = {"h": "http://www.w3.org/1999/xhtml"}


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    out = tmp_path_factory.mktemp("contents")
    res = CliRunner().invoke(main, ["reproduce", "-o", str(out), "--scenarios", "const-bank", "-j", "1",
                                    "--estimators", "pif-paper,pif-modified,pif-rate,pif-gated,pif-smoother,uio",
                                    "--docs", str(out / "results.md")])
    assert res.exit_code == 0, res.output
    return out


def _html(path):
    return html5lib.parse(path.read_text(), treebuilder="etree", namespaceHTMLElements=True)


@pytest.mark.slow
def test_contents_list_links_to_every_section(reproduced):
    doc = _html(reproduced / "report.html")
    ids = {el.get("id") for el in doc.iter() if el.get("id")}
    heads = [el for el in doc.iter() if el.tag.split("}")[1] in ("h2", "h3")]
    contents = next(h for h in heads if "".join(h.itertext()) == "Contents")
    links = [a.get("href") for a in doc.iter("{%s}a" % NS["h"]) if (a.get("href") or "").startswith("#")]
    # every section below the contents is linked, and every link lands on a heading
    sections = [h.get("id") for h in heads if h is not contents]
    assert sections and [x[1:] for x in links] == sections
    assert all(x[1:] in ids for x in links)
    assert "accuracy-aims" in sections and "figures" in sections and "const-bank" in sections
    # the markdown's links are the same anchors (GitHub's, for docs/results.md)
    md = (reproduced / "results.md").read_text()
    assert "- [Accuracy aims](#accuracy-aims)" in md and "(#figures)" not in md


@pytest.mark.slow
def test_one_accuracy_aims_table_for_every_pif_column(reproduced):
    md = (reproduced / "report.md").read_text()
    assert md.count("## Accuracy aims") == 1
    headers = [ln for ln in md.splitlines() if ln.startswith("| scenario | condition |") and "RMS / max" in ln]
    assert len(headers) == 1
    for n in ("pif-modified", "pif-rate", "pif-gated", "pif-smoother"):
        assert f"{n} RMS / max" in headers[0]
    assert "pif-paper RMS / max" not in headers[0]          # the paper's tuning is checked by the claims


def _cells(names):
    t = np.arange(0.0, 10.0, 0.01)
    ref = np.deg2rad(5.0) * (t > 3)
    inputs = {"steering_wheel_angle": 0.1 * np.sin(t), "vx": np.full_like(t, 20.0), "throttle": np.zeros_like(t)}
    rng = np.random.default_rng(0)
    return {c: CellResult("const-bank", c, t, inputs, ref, {n: ref + 0.02 * rng.standard_normal(t.size) for n in names},
                          {n: ref for n in names}, [])
            for c in ("nominal", "low-mu")}


def _drawn(monkeypatch, names_in_cells, names):
    got = {}
    monkeypatch.setattr(figures, "_save", lambda fig, path: got.setdefault("fig", fig) and [path])
    figures.scenario_figure("const-bank", _cells(names_in_cells), "x", names=names)
    return got["fig"]


def test_figure_draws_the_chosen_estimators_under_the_reference(monkeypatch):
    fig = _drawn(monkeypatch, ["pif-modified", "pif-rate", "pif-gated", "pif-smoother", "uio"],
                 ("pif-rate", "pif-gated", "pif-smoother"))
    fig.canvas.draw()
    for ax in fig.axes[1:]:
        lines = {ln.get_label(): ln for ln in ax.get_lines()}
        est = [k for k in lines if not k.startswith("Reference")]
        assert len(est) == 3 and all(any(n in k for k in est) for n in ("pif-rate", "pif-gated", "pif-smoother"))
        assert not any("uio" in k or "(pif-modified)" in k for k in est)
        ref = lines["Reference (true bank)"]
        assert all(ref.get_zorder() > lines[k].get_zorder() for k in est)
    legends = [(ax.get_legend(), ax) for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == 2                  # the inputs' and the estimates' (same in every panel)
    for leg, ax in legends:                   # right of its axes: over no curve
        assert leg.get_window_extent().x0 >= ax.get_window_extent().x1
    matplotlib.pyplot.close(fig)


def test_default_figures_show_the_variants_the_tables_favour(monkeypatch):
    fig = _drawn(monkeypatch, ["pif-paper", "pif-modified", "pif-rate", "pif-gated", "pif-smoother", "kinematic"],
                 figures.FIGURE_SET)
    labels = [ln.get_label() for ln in fig.axes[1].get_lines()]
    for n in ("pif-rate", "pif-gated", "pif-smoother", "pif-paper", "pif-modified"):
        assert any(f"({n})" in lab for lab in labels), (n, labels)
    assert not any("kinematic" in lab.lower() for lab in labels)
    matplotlib.pyplot.close(fig)
