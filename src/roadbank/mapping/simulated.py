"""GNSS positions of a simulated run, from the road's geometry (to check bank maps on a known road).

The road's reference line is rebuilt from its curvature profile (heading
``psi(s) = int kappa ds``, position ``int (sin psi, cos psi) ds`` as east/north,
starting at the origin heading north); the vehicle's lateral offset ``n`` is
measured in the banked road surface, so its horizontal distance from the line is
``int_0^n cos(bank(s, n')) dn'``. East/north metres become lat/lon through the
map's :class:`~roadbank.mapping.geo.LocalProjection`.
"""

from __future__ import annotations

import numpy as np

from .geo import LocalProjection


def reference_line(road, s_max: float, ds: float = 0.25):
    """``(s, east, north, heading)`` of the road's reference line from s = 0 to ``s_max`` (m, m, m, rad)."""
    s = np.arange(0.0, s_max + ds, ds)
    kappa = road.curvature_at(s)
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (kappa[1:] + kappa[:-1]) * ds)])
    # heading measured from north, positive to the left (ISO yaw): east = -sin, north = cos
    east = np.concatenate([[0.0], np.cumsum(0.5 * (-np.sin(psi[1:]) - np.sin(psi[:-1])) * ds)])
    north = np.concatenate([[0.0], np.cumsum(0.5 * (np.cos(psi[1:]) + np.cos(psi[:-1])) * ds)])
    return s, east, north, psi


def run_positions(result, road, projection: LocalProjection, n_points: int = 16):
    """(lat_deg, lon_deg) of a :class:`roadbank.sim.SimResult`'s vehicle on ``road`` at its sensor times."""
    s_v, n_v = result.truth.s, result.truth.n
    if road.closed_length > 0:
        s_v = np.mod(s_v, road.closed_length)
    s, east, north, psi = reference_line(road, float(np.max(s_v)) + 1.0)
    e0, n0, p0 = (np.interp(s_v, s, a) for a in (east, north, psi))
    # horizontal offset of the lane: int_0^n cos(bank) dn' (trapezoid on n_points)
    frac = np.linspace(0.0, 1.0, n_points)
    cosb = np.cos(road.bank(np.repeat(s_v[:, None], n_points, 1), n_v[:, None] * frac[None, :]))
    h = n_v * np.trapezoid(cosb, frac, axis=1)
    # left normal of a line heading psi from north (positive left): (-cos psi, -sin psi) in (east, north)
    return projection.to_latlon(e0 - h * np.cos(p0), n0 - h * np.sin(p0))
