"""Incremental Parquet storage of a campaign: one part file per finished batch.

Layout of a campaign directory::

    OUTDIR/campaign.json          the campaign's settings (checked on --resume)
    OUTDIR/parts/part-*.parquet   result rows, one file per finished batch

A part is written to a temporary name and renamed into place, so a campaign
killed mid-write leaves no half file behind (a stray ``.tmp`` is ignored).
Resuming skips every run id already present in a part; reading de-duplicates
by ``(run_id, estimator)`` (first part wins), so a batch written twice — e.g. a
task retried by Dask after the client had already stored it — is counted once.
"""

from __future__ import annotations

import json
import os
import uuid
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

PARTS = "parts"
SETTINGS = "campaign.json"


class StoreError(ValueError):
    """The output directory cannot be used for this campaign (message says why)."""


def parts_dir(outdir) -> Path:
    return Path(outdir) / PARTS


def part_files(outdir) -> list[Path]:
    """Finished part files of ``outdir``, sorted by name."""
    d = parts_dir(outdir)
    return sorted(d.glob("part-*.parquet")) if d.is_dir() else []


def write_part(outdir, rows: list[dict], label: str) -> Path | None:
    """Write ``rows`` (dicts with the same keys) as one new part; atomic rename. None if no rows."""
    if not rows:
        return None
    d = parts_dir(outdir)
    d.mkdir(parents=True, exist_ok=True)
    table = pa.Table.from_pylist(rows)
    final = d / f"part-{label}-{uuid.uuid4().hex[:8]}.parquet"
    tmp = final.with_suffix(".parquet.tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, final)
    return final


def stored_run_ids(outdir) -> set[int]:
    """Run ids that already have rows in ``outdir``."""
    ids: set[int] = set()
    for f in part_files(outdir):
        try:
            col = pq.read_table(f, columns=["run_id"]).column("run_id").to_numpy()
        except Exception as exc:  # a corrupt part must not be silently skipped
            raise StoreError(f"{f}: unreadable part file ({exc}); delete it to re-run its runs") from None
        ids.update(int(i) for i in np.unique(col))
    return ids


def load(outdir):
    """All result rows of ``outdir`` as a pandas DataFrame, de-duplicated by (run_id, estimator)."""
    import pandas as pd

    files = part_files(outdir)
    if not files:
        raise StoreError(f"{outdir}: no results (no {PARTS}/part-*.parquet)")
    frames = []
    for f in files:
        try:
            frames.append(pq.read_table(f).to_pandas())
        except Exception as exc:
            raise StoreError(f"{f}: unreadable part file ({exc})") from None
    df = pd.concat(frames, ignore_index=True)
    df = df.drop_duplicates(subset=["run_id", "estimator"], keep="first")
    return df.sort_values(["run_id", "estimator"]).reset_index(drop=True)


def _differences(old: dict, new: dict, within: str = "") -> dict:
    """``{key: (stored, now)}`` of the settings ``new`` that differ from ``old``, a setting that is a mapping in both
    compared key by key (named ``options.rear_trim``); absent on one side is None."""
    out = {}
    for k in sorted(set(new) | (set(old) if within else set())):
        a, b = old.get(k), new.get(k)
        if isinstance(a, dict) and isinstance(b, dict):
            out.update(_differences(a, b, f"{within}{k}."))
        elif a != b:
            out[f"{within}{k}"] = (a, b)
    return out


def check_settings(outdir, settings: dict, resume: bool) -> None:
    """Record ``settings`` in a new campaign directory, or check them when resuming.

    Raises
    ------
    StoreError
        When ``outdir`` already holds results and ``resume`` is False, or when
        resuming with settings (seed, options) different from the stored ones.
    """
    out = Path(outdir)
    path = out / SETTINGS
    has_results = bool(part_files(out))
    if path.exists() and resume:
        try:
            old = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise StoreError(f"{path}: unreadable campaign settings ({exc})") from None
        diff = _differences(old, {k: v for k, v in settings.items() if k != "runs"})
        if diff:
            raise StoreError(f"{out}: cannot resume, settings differ from the stored campaign: "
                             + "; ".join(f"{k}: stored {a!r}, now {b!r}" for k, (a, b) in diff.items()))
    elif has_results and not resume:
        raise StoreError(f"{out}: already holds campaign results; use --resume to continue it "
                         "or choose another directory")
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(settings, indent=2, sort_keys=True))
