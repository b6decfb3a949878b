r"""Understeer gradient, axle cornering stiffnesses and steering offset from one linear regression.

Linear bicycle model (docs/models.md, original model), tyre forces :math:`F_{yf} = C_f\alpha_f`,
:math:`F_{yr} = C_r\alpha_r`. The two axle forces follow from the measured
motion, without the unknown lateral velocity:

.. math::
    m a_t = F_{yf} + F_{yr},\qquad I_z\dot r = L_f F_{yf} - L_r F_{yr}

(:math:`a_t` the tyre-force specific acceleration, see :func:`tyre_acceleration`),
and the slip angles differ by a known amount,
:math:`\alpha_f - \alpha_r = \delta_f - L r / v_x`. Hence

.. math::
    \delta_f - \frac{L r}{v_x} = K_{us}\, a_t + S \frac{I_z}{L}\dot r,\qquad
    K_{us} = \frac{m}{L}\Big(\frac{L_r}{C_f} - \frac{L_f}{C_r}\Big),\quad
    S = \frac{1}{C_f} + \frac{1}{C_r}

which is linear in :math:`(K_{us}, S)`. With a steering offset
:math:`b_\delta` (measured = true + offset) the left side gains the constant
:math:`b_\delta`. Steady cornering (:math:`\dot r = 0`) gives only
:math:`K_{us}`; the yaw transients (corner entries and exits, lane changes)
give :math:`S`, and then

.. math::
    \frac{1}{C_f} = \frac{K_{us}}{m} + \frac{L_f}{L} S,\qquad
    \frac{1}{C_r} = \frac{L_r}{L} S - \frac{K_{us}}{m}.

The relation holds on banked roads too (the bank enters :math:`a_t` and the
slip angles alike), needs ``m, Iz, Lf, Lr`` from the base vehicle (``S`` scales
with ``1/Iz``) and is exact for the linear model, so a zero-phase low-pass
applied to both sides keeps it exact while removing the noise. Uncertainty:
block bootstrap of the whole regression.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import cont2discrete, lfilter, lfiltic

from ..models.bicycle import understeer_gradient
from ..params import VehicleParams
from .blocks import bootstrap, chop, normal_equations, robust_std, solve
from .offsets import Offsets, straight_bias_bound, straight_steering_offset
from .prepare import derivative, lowpass
from .results import Quantity, measured, refused
from .segments import Segmented
from .settings import IdentifySettings


#: Largest Kus standard uncertainty always accepted (rad s^2/m, 0.03 deg per m/s^2): a near-neutral car
#: has Kus ~ 0, where a relative limit would refuse a well-determined value.
KUS_STD_FLOOR = 5e-4

#: Model error of Kus not seen by the bootstrap (rad s^2/m, 0.017 deg/g), added in quadrature:
#: on simulated drives (docs/identification.md) Kus is off by up to 5e-5 rad s^2/m for reasons the
#: linear model leaves out (drive force at the steered wheels, combined slip), the same in every
#: block, so no resampling can see it.
KUS_MODEL_FLOOR = 3e-5

#: Relative model error of Cf and Cr not seen by the bootstrap nor by the half-range, roll-gain and
#: (tested, not used) half-bandwidth or speed-split checks: on the simulated fleet the compact car's
#: Cf and Cr come out 1.3 % and 3 % low at every amplitude, bandwidth and speed. Added in quadrature.
CF_MODEL_FLOOR, CR_MODEL_FLOOR = 0.01, 0.02


#: Largest yaw-rate offset uncertainty (rad/s, 0.05 deg/s) accepted from the speed dependence alone.
YAW_OFFSET_MAX_STD = np.radians(0.05)
#: Smallest relative spread (std / mean) of 1/vx for that.
MIN_INV_SPEED_SPREAD = 0.05


def tyre_acceleration(ay: np.ndarray, fs: float, p: VehicleParams, roll_gain: float) -> np.ndarray:
    r"""Tyre-force specific acceleration :math:`a_t = (F_{yf}+F_{yr})/m` from the measured ``ay``.

    The accelerometer rolls with the body: it reads
    :math:`a_y = a_t + g\phi + (m_s h/m)\ddot\phi` (the sprung mass's roll
    acceleration moves the CG). The roll follows
    :math:`I_{xx}\ddot\phi + c\dot\phi + k\phi = m_s h a_y` scaled so that its
    steady gain per *cornering* acceleration is ``roll_gain``
    (``k_phi = m_s h/(k - m_s g h)`` for the base vehicle's roll data).

    Parameters
    ----------
    ay : array (m/s^2), offset removed, uniform sampling at ``fs`` (Hz)
    p : VehicleParams
        ``ms, h_roll, Ixx, k_roll, c_roll, m, g``.
    roll_gain : float
        Steady roll per cornering acceleration (rad per m/s^2).

    Returns
    -------
    array (m/s^2)
    """
    if roll_gain == 0.0 or len(ay) < 3:
        return np.asarray(ay, dtype=float).copy()
    wn2, c2 = p.k_roll / p.Ixx, p.c_roll / p.Ixx
    gain = roll_gain / (1.0 + p.g * roll_gain)   # roll per measured ay
    num, den = [gain * wn2], [1.0, c2, wn2]
    bd, ad, _ = cont2discrete((num, den), 1.0 / fs, method="bilinear")
    bd = np.ravel(bd)
    zi = lfiltic(bd, ad, np.full(2, gain * ay[0]), np.full(2, ay[0]))
    phi, _ = lfilter(bd, ad, ay, zi=zi)
    phi_dd = derivative(derivative(phi, fs), fs)
    return ay - p.g * phi - p.ms * p.h_roll / p.m * phi_dd


def regression_rows(seg: Segmented, off: Offsets, p: VehicleParams, roll_gain: float, s: IdentifySettings,
                    yaw_offset_column: bool = False):
    """Low-passed regression rows of one log.

    Returns ``X`` (n, 5) with columns ``[a_t (m/s^2), Iz/L dr/dt (N), 1, a_t^3, Iz/L dr/dt a_t^2]``
    (the last two absorb the tyres' and load transfer's loss of stiffness with
    lateral acceleration, so the first two give the small-signal values),
    ``y`` (n,) ``= delta_f - L r / vx`` (rad), both offset-corrected, and the
    mask of the rows in the linear range. With ``yaw_offset_column`` a sixth
    column ``-L/vx`` (s) carries the yaw-rate offset (when no straight gave it).
    """
    Xs, ys, masks = [], [], []
    L = p.L
    for piece in seg.pieces:
        rc = piece.r - off.r
        at = tyre_acceleration(piece.ay - off.ay, seg.fs, p, roll_gain)
        y = lowpass(piece.delta - L * rc / piece.vx, seg.fs, s.f_cut)
        a_f = lowpass(at, seg.fs, s.f_cut)
        rdot = derivative(lowpass(rc, seg.fs, s.f_cut), seg.fs)
        cols = [a_f, p.Iz / L * rdot, np.ones_like(y), a_f**3, p.Iz / L * rdot * a_f**2]
        if yaw_offset_column:
            cols.append(lowpass(-L / piece.vx, seg.fs, s.f_cut))
        Xs.append(np.column_stack(cols))
        ys.append(y)
        masks.append(piece.regress)
    if not Xs:
        return np.zeros((0, 6 if yaw_offset_column else 5)), np.zeros(0), np.zeros(0, dtype=bool)
    return np.concatenate(Xs), np.concatenate(ys), np.concatenate(masks)


def _blocks(rows, fs_list, s: IdentifySettings, ay_limit: float):
    """Per-block normal equations of the rows with |a_t| <= ``ay_limit`` (all logs stacked)."""
    k = rows[0][0].shape[1] if rows else 5
    XtX, Xty = [np.zeros((0, k, k))], [np.zeros((0, k))]
    for (X, y, m), fs in zip(rows, fs_list):
        n = int(round(s.block * fs))
        spans = chop(m & (np.abs(X[:, 0]) <= ay_limit), n, n // 2)
        if spans:
            a, b, _ = normal_equations(X, y, spans)
            XtX.append(a)
            Xty.append(b)
    return np.concatenate(XtX), np.concatenate(Xty)


def _stiffness(theta: np.ndarray, p: VehicleParams) -> tuple[np.ndarray, np.ndarray]:
    """(Cf, Cr) in N/rad from (Kus, S) arrays (inf / negative where the data allow no positive value)."""
    kus, S = theta[..., 0], theta[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        return 1.0 / (kus / p.m + p.Lf / p.L * S), 1.0 / (p.Lr / p.L * S - kus / p.m)


def identify_stiffness(segs: list[Segmented], offs: list[Offsets], p: VehicleParams, roll_gain: float,
                       s: IdentifySettings, offsets_std: tuple[float, float] | None,
                       roll_gain_std: float = 0.0) -> dict[str, Quantity]:
    """``Kus`` (rad s^2/m), ``Cf``, ``Cr`` (N/rad) and ``steering_offset`` (rad) from the logs.

    Parameters
    ----------
    segs : list of Segmented
        Usable logs.
    offs : list of Offsets
        Offsets to remove from each log.
    p : VehicleParams
        Base vehicle (m, Iz, Lf, Lr, roll data).
    roll_gain : float
        Steady roll per cornering acceleration (rad per m/s^2).
    s : IdentifySettings
    offsets_std : (float, float) or None
        Standard uncertainties of the yaw-rate (rad/s) and ay (m/s^2) offsets, propagated
        into the steering offset; None when they could not be identified (then the
        steering offset is refused: its constant mixes with them).
    roll_gain_std : float
        Uncertainty of ``roll_gain`` (rad per m/s^2); the change of the results when the
        roll gain is moved by it is added to their uncertainty.

    Returns
    -------
    dict name -> Quantity
    """
    yaw_col = offsets_std is None  # no straights: the yaw-rate offset has to come from the regression
    rows = [regression_rows(seg, off, p, roll_gain, s, yaw_col) for seg, off in zip(segs, offs)]
    fs_list = [seg.fs for seg in segs]
    XtX, Xty = _blocks(rows, fs_list, s, s.ay_max)
    n_corners = sum(seg.n_corners for seg in segs)
    corner_s = sum(seg.seconds["corners"] for seg in segs)
    out: dict[str, Quantity] = {}
    names = (("Kus", "rad s^2/m"), ("Cf", "N/rad"), ("Cr", "N/rad"), ("steering_offset", "rad"))
    if n_corners < s.min_corners or len(XtX) < s.min_blocks:
        why = (f"too few quasi-steady corners: {n_corners} (|ay| >= {s.corner_ay:g} m/s^2 held >= "
               f"{s.corner_min:g} s at >= {s.v_min:g} m/s, {corner_s:.1f} s in all) and "
               f"{len(XtX)} blocks of {s.block:g} s in the linear range (|ay| <= {s.ay_max:g} m/s^2); "
               f"needs >= {s.min_corners} corners and >= {s.min_blocks} blocks")
        out = {k: refused(k, u, why) for k, u in names}
        if offsets_std is not None:
            out["steering_offset"] = straight_steering_offset(segs, understeer_gradient(p), s, p.g)
        else:
            out["steering_offset"] = refused("steering_offset", "rad",
                                             "needs the sensor offsets from straight driving (see ay_offset) "
                                             "and cornering; " + why)
        return out
    theta = solve(XtX.sum(0), Xty.sum(0))
    boot = bootstrap(XtX, Xty, s.n_boot, s.seed)
    cf, cr = _stiffness(theta, p)
    cf_b, cr_b = _stiffness(boot, p)
    # model error: the same fit on the lower half of the linear range; the difference is added
    # to the bootstrap spread (it also carries the half fit's own noise: a conservative term)
    XtX_h, Xty_h = _blocks(rows, fs_list, s, s.ay_max / 2)
    sys = np.zeros(3)
    if len(XtX_h) >= s.min_blocks:
        th_h = solve(XtX_h.sum(0), Xty_h.sum(0))
        cf_h, cr_h = _stiffness(th_h, p)
        sys = np.nan_to_num(np.abs([theta[0] - th_h[0], cf - cf_h, cr - cr_h]), nan=np.inf)
    if roll_gain_std > 0:
        # the tyre forces come from ay through the roll model: propagate the roll gain's uncertainty
        rows_r = [regression_rows(seg, off, p, roll_gain + roll_gain_std, s, yaw_col)
                  for seg, off in zip(segs, offs)]
        th_r = solve(*(a.sum(0) for a in _blocks(rows_r, fs_list, s, s.ay_max)))
        cf_r, cr_r = _stiffness(th_r, p)
        sys = np.hypot(sys, np.nan_to_num(np.abs([theta[0] - th_r[0], cf - cf_r, cr - cr_r]), nan=np.inf))
    n_s = sum(int(m.sum()) / fs for (_, _, m), fs in zip(rows, fs_list))
    method = (f"linear regression (tyre forces from ay and dr/dt) over {len(XtX)} blocks (~{n_s:.0f} s); "
              f"block bootstrap + model-error term (fit on |ay| <= {s.ay_max / 2:g} m/s^2) + roll gain "
              f"{roll_gain:.3g} +- {roll_gain_std:.2g} rad/(m/s^2) propagated + model-error floor")
    kus_std = float(np.sqrt(robust_std(boot[:, 0]) ** 2 + sys[0] ** 2 + KUS_MODEL_FLOOR ** 2))
    if not kus_std <= max(s.max_rel_std * abs(theta[0]), KUS_STD_FLOOR):
        why = (f"understeer gradient not determined: {theta[0]:.2e} +- {kus_std:.1e} rad s^2/m; "
               f"needs more quasi-steady cornering (now {n_corners} corners, {corner_s:.1f} s)")
        out["Kus"] = refused("Kus", "rad s^2/m", why)
    else:
        out["Kus"] = Quantity("Kus", float(theta[0]), kus_std, "rad s^2/m", method)
    for name, val, b, extra, floor in (("Cf", cf, cf_b, sys[1], CF_MODEL_FLOOR),
                                       ("Cr", cr, cr_b, sys[2], CR_MODEL_FLOOR)):
        sd = float(np.sqrt(robust_std(b) ** 2 + extra**2 + (floor * val) ** 2))
        bad = float(np.mean(~np.isfinite(b) | (b <= 0)))
        if not (np.isfinite(val) and val > 0 and bad < 0.025 and sd <= s.max_rel_std * val):
            rel = f"{100 * sd / val:.0f} %" if np.isfinite(val) and val > 0 and np.isfinite(sd) else "unbounded"
            why = (f"{name} not separable from the understeer gradient: relative uncertainty {rel} "
                   f"(limit {100 * s.max_rel_std:.0f} %); needs more yaw transients "
                   f"(corner entries and exits, lane changes) in the linear range")
            out[name] = refused(name, "N/rad", why)
        else:
            out[name] = Quantity(name, float(val), sd, "N/rad",
                                 method + f"; needs m, Iz, Lf, Lr of the base vehicle (Iz {p.Iz:g} kg m^2)")
    if offsets_std is not None:
        # the intercept absorbs the offsets' errors: L/vx per yaw-rate error, Kus per ay error
        inv_vx = np.mean(np.concatenate([1.0 / pc.vx[pc.regress] for seg in segs for pc in seg.pieces]))
        prop = np.hypot(p.L * inv_vx * offsets_std[0], theta[0] / (1.0 + p.g * roll_gain) * offsets_std[1])
        sd = float(np.sqrt(robust_std(boot[:, 2]) ** 2 + straight_bias_bound(segs, "delta", s) ** 2 + prop**2))
        out["steering_offset"] = measured("steering_offset", float(theta[2]), sd, "rad",
                                          "road-wheel angle, measured minus true; constant of the regression; "
                                          "block bootstrap + quantisation bias bound + offsets' uncertainty")
    else:
        out["steering_offset"] = refused("steering_offset", "rad",
                                         "needs the sensor offsets from straight driving (see ay_offset): "
                                         "without them the constant mixes steering and ay offsets")
        out["yaw_rate_offset"] = _yaw_offset_from_speed_spread(theta, boot, segs, s)
    return out


def _yaw_offset_from_speed_spread(theta, boot, segs: list[Segmented], s: IdentifySettings) -> Quantity:
    """The yaw-rate offset (rad/s) as the coefficient of ``-L/vx``: without straights it separates
    from the steering offset only through the speed dependence, so it needs a spread of speeds."""
    vx = np.concatenate([pc.vx[pc.regress] for seg in segs for pc in seg.pieces])
    sd = robust_std(boot[:, 5])
    spread = float(np.std(1.0 / vx) / np.mean(1.0 / vx))
    # with (nearly) one speed the column is collinear with the constant: the least-squares solution
    # is then a minimum-norm split whose bootstrap spread means nothing, so the spread is checked first
    if not (spread >= MIN_INV_SPEED_SPREAD and sd <= YAW_OFFSET_MAX_STD):
        return refused("yaw_rate_offset", "rad/s",
                       f"no straight driving, and too little speed spread to tell the yaw-rate offset from the "
                       f"steering offset through L/vx: speeds {vx.min():.1f}-{vx.max():.1f} m/s (1/vx varies by "
                       f"{100 * spread:.0f} %) give +-{np.degrees(sd):.2f} deg/s (limit "
                       f"{np.degrees(YAW_OFFSET_MAX_STD):.2f}, spread >= {100 * MIN_INV_SPEED_SPREAD:.0f} %); "
                       f"needs straights or cornering at several speeds")
    return Quantity("yaw_rate_offset", float(theta[5]), sd, "rad/s",
                    f"no straights: coefficient of L/vx in the regression (speeds {vx.min():.1f}-{vx.max():.1f} m/s); "
                    f"block bootstrap")
