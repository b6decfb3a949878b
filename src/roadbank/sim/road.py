"""Roads: curvature, grade and a bank that varies along the path and across it.

A road is described in curvilinear (Frenet) coordinates around a reference
line: path distance ``s`` (m) along the line and lateral offset ``n`` (m, left
positive) measured in the road surface. All profiles are piecewise linear in
their knots and held constant beyond the end knots:

* ``curvature(s)`` (1/m): in-surface (geodesic) curvature of the reference
  line, positive turning left. On a banked curve whose lanes are horizontal
  circles it equals the horizontal curvature times ``cos(bank)``.
* ``grade(s)`` (rad): positive nose up (uphill).
* ``bank(s, n) = bank_factor(s) * bank_profile(n)`` (rad): positive = left side
  up (ISO). The profile across the road lets a flat lane lie beside a banked
  one, or a track's bank grow towards the outer lanes; the factor along ``s``
  fades the bank in and out (e.g. in a curve's entry transition).

Truth bank
----------
Like CarSim, the truth road bank ``phi_b`` is computed from the heights of the
left and right tyre contact points: the surface height across the road is
``z(n) = int_0^n sin(bank) dn'`` and its horizontal coordinate
``h(n) = int_0^n cos(bank) dn'``; per axle ``phi_b = atan2(z_L - z_R, h_L - h_R)``,
averaged over the two axles (:func:`truth_bank`). On a uniformly banked road it
is exactly the road bank.

The plant uses the cheaper *secant bank* :func:`bank_under_vehicle` (the mean of
the profile between the wheel tracks, with the vehicle aligned with the road),
which differs from the contact-height bank by O(bank * dbank^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

LANE_WIDTH_TRACK = 16.2 / 4.0  #: lane width of the test track (m)
_HDR = 10  # header length of the packed road


def knots(label, xs, ys, increasing=True):
    """Validated knot arrays ``(x, y)`` of a piecewise profile; ``label`` (e.g. ``"Road.grade"``)
    names the field in the error messages."""
    x = np.atleast_1d(np.asarray(xs, dtype=np.float64))
    y = np.atleast_1d(np.asarray(ys, dtype=np.float64))
    if x.ndim != 1 or x.shape != y.shape or len(x) == 0:
        raise ValueError(f"{label}: knots must be two 1-D arrays of equal, non-zero length")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError(f"{label}: knots must be finite")
    if increasing and len(x) > 1 and np.any(np.diff(x) <= 0):
        raise ValueError(f"{label}: knot positions must be strictly increasing")
    return x, y


@dataclass(frozen=True)
class Road:
    """A road (see the module docstring for the coordinates and conventions).

    Parameters
    ----------
    curvature : (s_knots, kappa_knots)
        Reference-line curvature (1/m) against path distance (m).
    bank_profile : (n_knots, bank_knots)
        Bank (rad) across the road against lateral offset (m).
    bank_factor : (s_knots, factor_knots)
        Multiplier of the bank profile along the path (-).
    grade : (s_knots, grade_knots)
        Grade angle (rad) against path distance.
    lanes : dict name -> lateral offset (m) of the lane centre.
    closed_length : float
        If > 0 the road is a closed loop of this length and ``s`` wraps.
    name : str
    """

    curvature: tuple = ((0.0,), (0.0,))
    bank_profile: tuple = ((0.0,), (0.0,))
    bank_factor: tuple = ((0.0,), (1.0,))
    grade: tuple = ((0.0,), (0.0,))
    lanes: dict = field(default_factory=lambda: {"lane": 0.0})
    closed_length: float = 0.0
    name: str = "road"

    def __post_init__(self) -> None:
        for nm in ("curvature", "bank_profile", "bank_factor", "grade"):
            xs, ys = knots(f"Road.{nm}", *getattr(self, nm))
            object.__setattr__(self, nm, (xs, ys))
        if np.any(np.abs(self.bank_profile[1]) * np.max(np.abs(self.bank_factor[1])) >= math.radians(60)):
            raise ValueError("Road: |bank| must stay below 60 deg")
        if np.any(np.abs(self.grade[1]) >= math.radians(30)):
            raise ValueError("Road: |grade| must stay below 30 deg")
        if not (math.isfinite(self.closed_length) and self.closed_length >= 0):
            raise ValueError("Road.closed_length must be >= 0")

    def pack(self) -> np.ndarray:
        """One flat float64 array for the compiled code (header of offsets, then the knots).

        Layout: ``[closed_length, off_curv, n_curv, off_factor, n_factor, off_profile,
        n_profile, off_cum, off_grade, n_grade, <data>]``; passing one array (not a
        tuple of arrays) keeps the compiled calls free of reference counting.
        """
        pn, pb = self.bank_profile
        cum = np.zeros(len(pn))
        for k in range(1, len(pn)):
            cum[k] = cum[k - 1] + 0.5 * (pb[k] + pb[k - 1]) * (pn[k] - pn[k - 1])
        parts = [self.curvature[0], self.curvature[1], self.bank_factor[0], self.bank_factor[1],
                 pn, pb, cum, self.grade[0], self.grade[1]]
        header = np.zeros(_HDR)
        header[0] = self.closed_length
        off = _HDR
        offs = []
        for a in parts:
            offs.append(off)
            off += len(a)
        header[1], header[2] = offs[0], len(self.curvature[0])
        header[3], header[4] = offs[2], len(self.bank_factor[0])
        header[5], header[6] = offs[4], len(pn)
        header[7] = offs[6]
        header[8], header[9] = offs[7], len(self.grade[0])
        return np.concatenate([header] + [np.asarray(a, dtype=np.float64) for a in parts])

    # -- Python-side conveniences (vectorised over numpy arrays) -------------
    def bank(self, s, n):
        """Road bank (rad) at path distance ``s`` and offset ``n`` (profile value, no averaging)."""
        s = self._wrap(np.asarray(s, dtype=float))
        return np.interp(s, *self.bank_factor) * np.interp(n, *self.bank_profile)

    def curvature_at(self, s):
        """Reference-line curvature (1/m) at ``s``."""
        return np.interp(self._wrap(np.asarray(s, dtype=float)), *self.curvature)

    def grade_at(self, s):
        """Grade (rad) at ``s``."""
        return np.interp(self._wrap(np.asarray(s, dtype=float)), *self.grade)

    def _wrap(self, s):
        return np.mod(s, self.closed_length) if self.closed_length > 0 else s


# ---- constructors --------------------------------------------------------------

def straight_road(bank: float = 0.0, grade: float = 0.0, name: str = "straight") -> Road:
    """Straight road with a uniform bank (rad, left side up positive) and grade (rad)."""
    return Road(bank_profile=((0.0,), (bank,)), grade=((0.0,), (grade,)), name=name)


def flat_road() -> Road:
    """Flat, straight, unbounded road (for open-loop manoeuvres such as the S-curve)."""
    return straight_road(0.0, 0.0, name="flat")


def two_lane_road(bank_left: float = math.atan(0.25), bank_right: float = 0.0,
                  lane_width: float = 3.5, transition: float = 1.0) -> Road:
    """Straight road with two lanes of different bank (rad).

    The right lane (centre ``-lane_width/2``) has bank ``bank_right``, the left
    lane (``+lane_width/2``) ``bank_left``; the bank changes linearly over a strip
    ``transition`` wide (m) centred on the lane line, so the surface has a
    crease there, as a banked lane next to a flat one does.
    """
    if transition <= 0 or transition >= lane_width:
        raise ValueError("two_lane_road: need 0 < transition < lane_width")
    h = transition / 2.0
    return Road(bank_profile=((-h, h), (bank_right, bank_left)),
                lanes={"right": -lane_width / 2.0, "left": lane_width / 2.0}, name="two-lane")


#: Banks of the test-track lanes in the curves (rad), lane 1 (inner) to 4 (outer).
TRACK_LANE_BANKS_DEG = (10.0, 20.0, 30.0, 40.0)


def test_track(radius: float = 300.0, straight: float = 500.0, transition: float = 100.0,
               lane_banks_deg=TRACK_LANE_BANKS_DEG) -> Road:
    """High-speed oval: two straights and two banked 180-degree curves, 4 lanes, 16.2 m wide.

    Driven clockwise (right-hand curves), so the inside is on the right and the
    banks are positive (left side up), as in the paper's figures. The reference
    line runs along the track centre (between lanes 2 and 3); lane ``k`` has its
    centre at ``n = (k - 2.5) * 4.05`` m (lane 1 innermost, ``n = -6.075``).

    Geometry (along ``s``): straight, a clothoid-like entry transition of length
    ``transition`` in which curvature and bank ramp linearly, an arc of radius
    ``radius`` (at the reference line), an exit transition, and the same again.
    Across the road the curve bank is piecewise linear through the lane centres
    (``lane_banks_deg``, default 10/20/30/40 deg), constant beyond lanes 1 and 4.
    The straights are flat.

    The default radius (300 m) makes lane 3 (30 deg) nearly neutral at the
    paper's 140 km/h and lane 1 (10 deg) need about 3.7 m/s^2 of lateral force
    at 143 km/h, in line with the paper's Fig 6-7 signal levels.
    """
    w = LANE_WIDTH_TRACK
    centres = [(k - 2.5) * w for k in (1, 2, 3, 4)]
    kap = -1.0 / radius
    arc = math.pi * radius - transition
    s, k, f = [0.0], [0.0], [0.0]
    pos = 0.0
    for _ in range(2):
        pos += straight
        s += [pos]; k += [0.0]; f += [0.0]
        pos += transition
        s += [pos]; k += [kap]; f += [1.0]
        pos += arc
        s += [pos]; k += [kap]; f += [1.0]
        pos += transition
        s += [pos]; k += [0.0]; f += [0.0]
    banks = [math.radians(b) for b in lane_banks_deg]
    return Road(curvature=(s, k), bank_factor=(s, f), bank_profile=(centres, banks),
                lanes={f"lane{i + 1}": c for i, c in enumerate(centres)},
                closed_length=pos, name="test-track")


def track_curve_start(road: Road) -> float:
    """Path distance (m) where the first arc of :func:`test_track` starts (after its entry transition)."""
    s, k = road.curvature
    return float(s[2])


# ---- compiled lookups ------------------------------------------------------------
# All take the packed road (one float64 array, see Road.pack).

@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def _wrap(road, s):
    L = road[0]
    if L > 0.0:
        s = s - L * math.floor(s / L)
    return s


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def interp1(a, off, n, x):
    """Piecewise-linear interpolation of knots ``a[off:off+n]`` (x) -> ``a[off+n:off+2n]`` (y), held at the ends."""
    ys = off + n
    if n == 1 or x <= a[off]:
        return a[ys]
    if x >= a[off + n - 1]:
        return a[ys + n - 1]
    lo, hi = 0, n - 1
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if a[off + mid] <= x:
            lo = mid
        else:
            hi = mid
    x0 = a[off + lo]
    u = (x - x0) / (a[off + hi] - x0)
    return a[ys + lo] + u * (a[ys + hi] - a[ys + lo])


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def road_curvature(road, s):
    """Reference-line curvature (1/m) at ``s``."""
    return interp1(road, np.int64(road[1]), np.int64(road[2]), _wrap(road, s))


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def road_grade(road, s):
    """Grade (rad) at ``s``."""
    return interp1(road, np.int64(road[8]), np.int64(road[9]), _wrap(road, s))


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def road_bank_factor(road, s):
    """Bank factor (-) at ``s``."""
    return interp1(road, np.int64(road[3]), np.int64(road[4]), _wrap(road, s))


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def _profile_integral(road, n):
    """int_{n_0}^{n} bank_profile(n') dn' (rad m), n_0 the first profile knot."""
    off = np.int64(road[5])
    m = np.int64(road[6])
    pb = off + m
    cum = np.int64(road[7])
    if n <= road[off] or m == 1:
        return road[pb] * (n - road[off])
    if n >= road[off + m - 1]:
        return road[cum + m - 1] + road[pb + m - 1] * (n - road[off + m - 1])
    k = 0
    while road[off + k + 1] < n:
        k += 1
    d = n - road[off + k]
    slope = (road[pb + k + 1] - road[pb + k]) / (road[off + k + 1] - road[off + k])
    return road[cum + k] + road[pb + k] * d + 0.5 * slope * d * d


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy")
def bank_under_vehicle(road, s, n, half_track):
    """Secant bank (rad): bank factor at ``s`` times the mean profile over ``n +- half_track``."""
    return road_at(road, s, n, half_track)[2]


@njit(cache=True, forceinline=True, fastmath=True, error_model="numpy", no_cpython_wrapper=True,
      no_cfunc_wrapper=True)
def road_at(road, s, n, half_track):
    """``(curvature (1/m), grade (rad), secant bank (rad))`` at ``(s, n)``: what the plant reads.

    :func:`road_curvature`, :func:`road_grade` and :func:`bank_under_vehicle` in
    one call that wraps ``s`` once (the plant's evaluation calls only this).
    """
    sw = _wrap(road, s)
    kap = interp1(road, np.int64(road[1]), np.int64(road[2]), sw)
    grade = interp1(road, np.int64(road[8]), np.int64(road[9]), sw)
    factor = interp1(road, np.int64(road[3]), np.int64(road[4]), sw)
    if np.int64(road[6]) == 1:
        return kap, grade, factor * road[np.int64(road[5]) + 1]
    mean = (_profile_integral(road, n + half_track) - _profile_integral(road, n - half_track)) / (2.0 * half_track)
    return kap, grade, factor * mean


@njit(cache=True)
def _seg_int(f, b0, slope, a, b):
    """(int sin(f*bank), int cos(f*bank)) over [a, b] where bank(n') = b0 + slope*(n' - a)."""
    d = b - a
    if d == 0.0:
        return 0.0, 0.0
    t0 = f * b0
    t1 = f * (b0 + slope * d)
    if abs(t1 - t0) < 1e-9:
        tm = 0.5 * (t0 + t1)
        return math.sin(tm) * d, math.cos(tm) * d
    k = d / (t1 - t0)
    return (math.cos(t0) - math.cos(t1)) * k, (math.sin(t1) - math.sin(t0)) * k


@njit(cache=True)
def contact_height(road, s, n):
    """Surface height ``z`` and horizontal coordinate ``h`` (m) at ``(s, n)``, relative to the first profile knot."""
    f = interp1(road, np.int64(road[3]), np.int64(road[4]), _wrap(road, s))      # road_bank_factor
    off = np.int64(road[5])
    m = np.int64(road[6])
    pb = off + m
    if n <= road[off] or m == 1:
        if n >= road[off]:
            return _seg_int(f, road[pb], 0.0, road[off], n)
        z, h = _seg_int(f, road[pb], 0.0, n, road[off])
        return -z, -h
    z, h = 0.0, 0.0
    k = 0
    while k < m - 1 and road[off + k + 1] <= n:
        slope = (road[pb + k + 1] - road[pb + k]) / (road[off + k + 1] - road[off + k])
        dz, dh = _seg_int(f, road[pb + k], slope, road[off + k], road[off + k + 1])
        z += dz
        h += dh
        k += 1
    if k < m - 1:
        slope = (road[pb + k + 1] - road[pb + k]) / (road[off + k + 1] - road[off + k])
    else:
        slope = 0.0
    dz, dh = _seg_int(f, road[pb + k], slope, road[off + k], n)
    return z + dz, h + dh


@njit(cache=True)
def truth_bank(road, s, n, psi, lf, lr, tf, tr):
    """Truth bank (rad) from the left/right contact heights, averaged over both axles.

    ``psi`` is the heading relative to the reference line (rad); wheel contact
    points are at body ``(lf, +-tf/2)`` and ``(-lr, +-tr/2)``. Per axle
    ``atan2(z_L - z_R, d)`` with ``d`` the horizontal distance of the contacts.
    """
    c = math.cos(psi)
    sn = math.sin(psi)
    tot = 0.0
    for axle in range(2):
        x = lf if axle == 0 else -lr
        hw = 0.5 * (tf if axle == 0 else tr)
        sl = s + x * c - hw * sn
        nl = n + x * sn + hw * c
        sr = s + x * c + hw * sn
        nr = n + x * sn - hw * c
        zl, hl = contact_height(road, sl, nl)
        zr, hr = contact_height(road, sr, nr)
        # horizontal distance between the contacts (across and along the road)
        dh = hl - hr
        ds = sl - sr
        dist = math.sqrt(dh * dh + ds * ds)
        tot += math.atan2(zl - zr, dist)
    return 0.5 * tot


@njit(cache=True)
def truth_banks(road, s, n, psi, lf, lr, tf, tr):
    """:func:`truth_bank` (rad) at each of the positions ``s``, ``n`` (m) and headings ``psi`` (rad; arrays of one
    length): one compiled loop, the same values to the bit."""
    out = np.empty(len(s))
    for k in range(len(s)):
        out[k] = truth_bank(road, s[k], n[k], psi[k], lf, lr, tf, tr)
    return out
