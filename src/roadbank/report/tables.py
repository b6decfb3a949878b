"""Tidy metric tables (CSV + Parquet), the pivoted summaries used by the report, and the table of the default's
targets (:func:`targets_markdown`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from ..defaults import ESTIMATOR as DEFAULT
from .labels import label
from .markdown import Markdown, md_table

COLUMNS = ("scenario", "condition", "estimator", "reference", "metric", "value")


def write_tables(rows: list[dict], outdir: Path) -> list[Path]:
    """Write ``metrics.csv`` and ``metrics.parquet`` (columns :data:`COLUMNS`; deg / s)."""
    table = pa.table({c: [r[c] for r in rows] for c in COLUMNS})
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, outdir / "metrics.parquet")
    pacsv.write_csv(table, outdir / "metrics.csv")
    return [outdir / "metrics.csv", outdir / "metrics.parquet"]


def lookup(rows: list[dict], reference: str, metric: str) -> dict:
    """``{(scenario, condition, estimator): value}`` for one reference and metric."""
    return {(r["scenario"], r["condition"], r["estimator"]): r["value"] for r in rows
            if r["reference"] == reference and r["metric"] == metric}


def cell_order(rows: list[dict]) -> tuple[list, list]:
    """Ordered unique (scenario, condition) cells and estimator names of ``rows``."""
    cells, names = [], []
    for r in rows:
        key = (r["scenario"], r["condition"])
        if key not in cells:
            cells.append(key)
        if r["estimator"] not in names:
            names.append(r["estimator"])
    return cells, names


def markdown_table(rows: list[dict], reference: str, metric: str, *, digits: int = 2,
                   highlight_best: bool = True) -> str:
    """Markdown table of one reference and metric: one line per cell, one column per
    estimator; the best (smallest magnitude) value of each line in bold."""
    values = lookup(rows, reference, metric)
    cells, names = cell_order(rows)
    body = [[sc, cond] + [values.get((sc, cond, n), np.nan) for n in names] for sc, cond in cells]
    return md_table(["scenario", "condition"] + [label(n) for n in names], body, digits=digits,
                    best="absmin" if highlight_best else None)


def targets_markdown(targets) -> list[str]:
    """Markdown lines: a table of ``targets`` (:class:`~roadbank.evaluation.targets.Target`: data, target,
    measured, met), then an empty line; nothing when there are none."""
    if not targets:
        return []
    rows = [[t.data, t.text, t.measured, Markdown("yes" if t.met else "**no**")] for t in targets]
    return [md_table(["data", f"target of the default ({DEFAULT})", "measured", "met?"], rows, align="llll"), ""]
