"""Aggregation of bank estimates per road cell: square cells of the local plane x heading sectors.

A cell is ``(ix, iy) = floor((east, north) / cell_m)`` in the map's
:class:`~roadbank.mapping.geo.LocalProjection`. The road bank angle is measured
in the vehicle's frame (positive = left side up, ISO 8855), so the same
carriageway driven in opposite directions reads opposite signs: every cell is
split into ``sectors`` heading sectors (course over ground, sector 0 centred on
north, clockwise), and a row of the map is one (cell, sector). Per row: the
number of valid samples, the number of logs, the mean, sample standard
deviation, minimum and maximum of the bank (deg). Samples are weighted
equally (a slow pass contributes more samples than a fast one). The statistics are running
sums, so maps of separate logs on one grid merge into the map of all of them
(:meth:`BankMap.merge`, equal up to the rounding of the sums): how ``roadbank map --workers``
combines the logs mapped on the workers.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io.writers import write_error, write_table
from .geo import LocalProjection, course

#: columns of the map table, in order
MAP_COLUMNS = ("ix", "iy", "sector", "lat_deg", "lon_deg", "heading_deg", "count", "logs",
               "bank_mean_deg", "bank_std_deg", "bank_min_deg", "bank_max_deg")


#: the cell sizes (m) a map may have: finer than a GNSS fix is no use, and a local projection holds a few tens of km
#: (a 1e9 m cell put its centre at latitude 4534 deg)
CELL_RANGE_M = (0.1, 10_000.0)
#: heading sectors per cell: 1 (none) to 10 deg each
SECTOR_RANGE = (1, 36)


@dataclass
class BankMap:
    """Running per-cell statistics of the road bank (see the module doc).

    Parameters
    ----------
    projection : LocalProjection
        The map's plane (origin).
    cell_m : float
        Cell edge (m), default 10.
    sectors : int
        Heading sectors per cell (default 4: N, E, S, W +-45 deg); 1 ignores the heading.
    """

    projection: LocalProjection
    cell_m: float = 10.0
    sectors: int = 4
    _stats: dict = field(default_factory=dict, repr=False)   # (ix, iy, s) -> [n, sum, sumsq, min, max] (rad)
    _logs: dict = field(default_factory=dict, repr=False)    # (ix, iy, s) -> set of log ids

    def __post_init__(self):
        lo, hi = CELL_RANGE_M
        if not lo <= self.cell_m <= hi:
            raise ValueError(f"cell size must be {lo:g}-{hi:g} m, got {self.cell_m}")
        if not SECTOR_RANGE[0] <= int(self.sectors) <= SECTOR_RANGE[1]:
            raise ValueError(f"sectors must be {SECTOR_RANGE[0]}-{SECTOR_RANGE[1]}, got {self.sectors}")
        self.sectors = int(self.sectors)

    def add(self, lat_deg, lon_deg, phi_b, valid, log_id=0, course_rad=None) -> int:
        """Add one stretch of consecutive samples of one log.

        Parameters
        ----------
        lat_deg, lon_deg : arrays
            Position (deg) of each sample (NaN: no fix).
        phi_b : array
            Road bank estimate (rad, ISO: left side up).
        valid : bool array
            The estimator's validity flag; invalid samples are not mapped.
        log_id : hashable
            Counts the distinct logs per cell.
        course_rad : array, optional
            Course over ground of each sample (rad, clockwise from north; NaN: unknown); default
            :func:`~roadbank.mapping.geo.course` of this stretch (a stretch cut out of a longer
            track then has no course near its ends: :class:`~roadbank.mapping.geo.CourseStream`
            gives a streamed track the course of the whole).

        Returns
        -------
        int
            Samples added.
        """
        lat, lon = np.asarray(lat_deg, float), np.asarray(lon_deg, float)
        e, n = self.projection.to_en(lat, lon)
        crs = course(e, n) if course_rad is None else np.asarray(course_rad, float)
        pb = np.asarray(phi_b, float)
        ok = np.asarray(valid, bool) & np.isfinite(e) & np.isfinite(n) & np.isfinite(pb)
        if self.sectors > 1:
            ok &= np.isfinite(crs)
        if not ok.any():
            return 0
        ix = np.floor(e[ok] / self.cell_m).astype(np.int64)
        iy = np.floor(n[ok] / self.cell_m).astype(np.int64)
        width = 2 * np.pi / self.sectors
        sec = (np.floor(np.mod(crs[ok] + width / 2, 2 * np.pi) / width).astype(np.int64) % self.sectors
               if self.sectors > 1 else np.zeros(len(ix), np.int64))
        v = pb[ok]
        keys, inv = np.unique(np.stack([ix, iy, sec], axis=1), axis=0, return_inverse=True)
        inv = inv.ravel()
        m = len(keys)
        cnt = np.bincount(inv, minlength=m)
        s1 = np.bincount(inv, weights=v, minlength=m)
        s2 = np.bincount(inv, weights=v * v, minlength=m)
        lo = np.full(m, np.inf)
        hi = np.full(m, -np.inf)
        np.minimum.at(lo, inv, v)
        np.maximum.at(hi, inv, v)
        for j, key in enumerate(map(tuple, keys.tolist())):
            st = self._stats.get(key)
            if st is None:
                self._stats[key] = [int(cnt[j]), s1[j], s2[j], lo[j], hi[j]]
                self._logs[key] = {log_id}
            else:
                st[0] += int(cnt[j])
                st[1] += s1[j]
                st[2] += s2[j]
                st[3] = min(st[3], lo[j])
                st[4] = max(st[4], hi[j])
                self._logs[key].add(log_id)
        return int(ok.sum())

    def merge(self, other: "BankMap") -> "BankMap":
        """Add the samples of another map on the same grid (projection, cell, sectors), as if they
        had been added here: counts and sums add, minimum and maximum combine, the logs of a cell
        are the union of both maps' log ids (so the ids must name the same logs in both).

        Returns
        -------
        BankMap
            This map (``other`` is not changed).

        Raises
        ------
        ValueError
            The grids differ.
        """
        if (other.projection, float(other.cell_m), other.sectors) != (self.projection, float(self.cell_m),
                                                                      self.sectors):
            raise ValueError(f"cannot merge a map of origin {other.projection}, cell {other.cell_m:g} m, "
                             f"{other.sectors} sector(s) into one of origin {self.projection}, cell "
                             f"{self.cell_m:g} m, {self.sectors} sector(s)")
        for key, st in other._stats.items():
            mine = self._stats.get(key)
            if mine is None:
                self._stats[key] = list(st)
                self._logs[key] = set(other._logs[key])
            else:
                mine[0] += st[0]
                mine[1] += st[1]
                mine[2] += st[2]
                mine[3] = min(mine[3], st[3])
                mine[4] = max(mine[4], st[4])
                self._logs[key] |= other._logs[key]
        return self

    def __len__(self) -> int:
        return len(self._stats)

    def table(self) -> dict[str, np.ndarray]:
        """The map as columns (:data:`MAP_COLUMNS`), sorted by (iy, ix, sector); angles in deg."""
        keys = sorted(self._stats, key=lambda k: (k[1], k[0], k[2]))
        st = np.array([self._stats[k] for k in keys], dtype=float).reshape(-1, 5)
        k = np.array(keys, dtype=np.int64).reshape(-1, 3)
        n = st[:, 0]
        mean = st[:, 1] / np.maximum(n, 1)
        var = np.where(n > 1, (st[:, 2] - n * mean ** 2) / np.maximum(n - 1, 1), np.nan)
        lat, lon = self.projection.to_latlon((k[:, 0] + 0.5) * self.cell_m, (k[:, 1] + 0.5) * self.cell_m)
        return {"ix": k[:, 0], "iy": k[:, 1], "sector": k[:, 2], "lat_deg": lat, "lon_deg": lon,
                "heading_deg": k[:, 2] * (360.0 / self.sectors) if self.sectors > 1 else np.full(len(k), np.nan),
                "count": n.astype(np.int64), "logs": np.array([len(self._logs[x]) for x in keys], dtype=np.int64),
                "bank_mean_deg": np.degrees(mean), "bank_std_deg": np.degrees(np.sqrt(np.maximum(var, 0.0))),
                "bank_min_deg": np.degrees(st[:, 3]), "bank_max_deg": np.degrees(st[:, 4])}

    def metadata(self) -> dict[str, str]:
        """What the map's numbers mean (stored in the Parquet schema)."""
        return {"origin_lat_deg": repr(self.projection.lat0_deg), "origin_lon_deg": repr(self.projection.lon0_deg),
                "cell_m": repr(self.cell_m), "sectors": str(self.sectors),
                "projection": "equirectangular about the origin, WGS-84 mean radius",
                "bank_sign": "ISO 8855, vehicle frame: positive = left side up in the sector's heading"}

    def write_parquet(self, path, extra_metadata: dict | None = None) -> Path:
        """The table with :meth:`metadata` (plus ``extra_metadata``) in the schema."""
        return write_table(path, self.table(), dict(self.metadata(), **(extra_metadata or {})), format="parquet")

    def write_geojson(self, path) -> Path:
        """One Polygon feature per (cell, sector) with the table's values as properties. A path that cannot be
        written is a :class:`~roadbank.io.writers.WriteError` naming it."""
        tab = self.table()
        feats = []
        for j in range(len(tab["ix"])):
            e0, n0 = tab["ix"][j] * self.cell_m, tab["iy"][j] * self.cell_m
            es = np.array([e0, e0 + self.cell_m, e0 + self.cell_m, e0, e0])
            ns = np.array([n0, n0, n0 + self.cell_m, n0 + self.cell_m, n0])
            la, lo = self.projection.to_latlon(es, ns)
            props = {c: (None if isinstance(tab[c][j], float) and math.isnan(tab[c][j]) else tab[c][j].item())
                     for c in MAP_COLUMNS}
            feats.append({"type": "Feature", "properties": props,
                          "geometry": {"type": "Polygon",
                                       "coordinates": [[[round(float(a), 8), round(float(b), 8)]
                                                        for a, b in zip(lo, la)]]}})
        doc = {"type": "FeatureCollection", "features": feats,
               "properties": {k: v for k, v in self.metadata().items()}}
        return _write(path, lambda p: p.write_text(json.dumps(doc)))

    def plot(self, path, title: str = "") -> Path:
        """PNG (or SVG by suffix): cells in the local plane coloured by mean bank (deg). A path that cannot be
        written is a :class:`~roadbank.io.writers.WriteError` naming it."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        tab = self.table()
        fig, ax = plt.subplots(figsize=(8, 7))
        e = (tab["ix"] + 0.5) * self.cell_m
        n = (tab["iy"] + 0.5) * self.cell_m
        lim = max(1.0, float(np.nanpercentile(np.abs(tab["bank_mean_deg"]), 99))) if len(e) else 1.0
        order = np.argsort(tab["count"])
        sc = ax.scatter(e[order], n[order], c=tab["bank_mean_deg"][order], cmap="coolwarm", vmin=-lim, vmax=lim,
                        s=np.clip(4 + 2 * np.sqrt(tab["count"][order]), 4, 60), marker="s", linewidths=0)
        fig.colorbar(sc, ax=ax, label="mean road bank (deg, left side up)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(f"east of {self.projection.lon0_deg:.5f} deg (m)")
        ax.set_ylabel(f"north of {self.projection.lat0_deg:.5f} deg (m)")
        ax.set_title(title or f"bank map: {len(e)} cells of {self.cell_m:g} m x {self.sectors} heading sectors",
                     fontsize=10)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        try:
            return _write(path, lambda p: fig.savefig(p, dpi=110))
        finally:
            plt.close(fig)


def _write(path, write) -> Path:
    """``write(p)`` the file ``p = Path(path)``, its folder made first; an ``OSError`` is a
    :class:`~roadbank.io.writers.WriteError` naming the path and why (:func:`~roadbank.io.writers.write_error`)."""
    p = Path(path)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        write(p)
    except OSError as exc:
        raise write_error(p, exc) from exc
    return p
