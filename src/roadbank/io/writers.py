"""Writing estimation results: one table per log, CSV or Parquet.

Columns (SI): ``t`` (s), then for every estimator ``<name>.theta`` (rad, bank +
body roll), ``<name>.phi_b`` (rad, road bank), ``<name>.valid`` (0/1), and
``reference_roll`` (rad) when the log has one.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

OUTPUT_FORMATS = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}


def estimate_table(t, estimates, reference_roll=None) -> dict[str, np.ndarray]:
    """Columns of the output table, in order (see module doc)."""
    cols = {"t": np.asarray(t, dtype=np.float64)}
    for est in estimates:
        cols[f"{est.name}.theta"] = np.asarray(est.theta, dtype=np.float64)
        cols[f"{est.name}.phi_b"] = np.asarray(est.phi_b, dtype=np.float64)
        cols[f"{est.name}.valid"] = np.asarray(est.valid, dtype=bool)
    if reference_roll is not None:
        cols["reference_roll"] = np.asarray(reference_roll, dtype=np.float64)
    return cols


def write_table(path, cols: dict[str, np.ndarray], metadata: dict | None = None,
                format: str | None = None) -> Path:
    """Write ``cols`` to ``path`` as CSV (header line) or Parquet (``metadata`` in the schema)."""
    p = Path(path)
    fmt = format or OUTPUT_FORMATS.get(p.suffix.lower())
    if fmt not in ("csv", "parquet"):
        raise ValueError(f"{p}: output must end in .csv or .parquet")
    p.parent.mkdir(parents=True, exist_ok=True)
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq
        meta = {k: (v if isinstance(v, str) else json.dumps(v)) for k, v in (metadata or {}).items()}
        table = pa.table({k: pa.array(v) for k, v in cols.items()})
        table = table.replace_schema_metadata(meta)
        pq.write_table(table, p)
    else:
        names = list(cols)
        arrays = [cols[n].astype(int) if cols[n].dtype == bool else cols[n] for n in names]
        with open(p, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(names)
            for row in zip(*arrays):
                w.writerow([repr(float(x)) if isinstance(x, (float, np.floating)) else int(x) for x in row])
    return p
