r"""Roll gain from a roll reference (e.g. an IMU / pose roll angle in the log).

A roll reference of the body relative to gravity reads
:math:`\phi_{ref} = c + \phi_b + \phi`, with a constant mounting offset ``c``,
the road bank :math:`\phi_b` and the body roll :math:`\phi = k_\phi a_t`
(:math:`a_t = v_x r + g\sin\phi_b` in quasi-steady driving). Bank and roll
cannot be split from the signals alone; the identification assumes the bank is
not correlated with the cornering acceleration and regresses (per log, after
removing its means) the low-passed reference on the cornering acceleration
:math:`v_x r`:

.. math::
    \phi_{ref} - \bar\phi_{ref} = k_\phi (v_x r - \overline{v_x r}) + \text{bank}.

Superelevated corners (bank towards the inside, growing with :math:`v^2/R`)
violate the assumption and make :math:`k_\phi` too small. Uncertainty: block bootstrap.
"""

from __future__ import annotations

import numpy as np

from .blocks import bootstrap, chop, normal_equations, robust_std, solve
from .offsets import Offsets
from .prepare import lowpass
from .results import Quantity, refused
from .segments import Segmented
from .settings import IdentifySettings


def identify_roll_gain(segs: list[Segmented], offs: list[Offsets], s: IdentifySettings) -> Quantity:
    """Steady roll gain (rad per m/s^2) from the logs that carry a roll reference.

    Parameters
    ----------
    segs : list of Segmented
        Logs; those whose pieces have no ``roll`` are skipped.
    offs : list of Offsets
        Yaw-rate offsets to remove.
    s : IdentifySettings

    Returns
    -------
    Quantity
        ``roll_gain`` or its refusal.
    """
    XtX, Xty = [], []
    cornering = 0.0
    for seg, off in zip(segs, offs):
        xs, ys, masks = [], [], []
        for p in seg.pieces:
            if p.roll is None:
                continue
            xs.append(lowpass(p.vx * (p.r - off.r), seg.fs, s.f_cut))
            ys.append(lowpass(p.roll, seg.fs, s.f_cut))
            masks.append(p.regress)
        if not xs:
            continue
        x, y, m = np.concatenate(xs), np.concatenate(ys), np.concatenate(masks)
        if m.sum() < 2:
            continue
        x, y = x - x[m].mean(), y - y[m].mean()
        cornering += float(np.sum(m & (np.abs(x) >= s.corner_ay))) / seg.fs
        spans = chop(m, int(round(s.block * seg.fs)), int(round(s.block * seg.fs / 2)))
        a, b, _ = normal_equations(x[:, None], y, spans)
        XtX.append(a)
        Xty.append(b)
    need = 5.0
    if not XtX or cornering < need or sum(len(a) for a in XtX) < s.min_blocks:
        return refused("roll_gain", "rad/(m/s^2)",
                       f"the roll reference needs cornering: {cornering:.1f} s with |vx r| >= {s.corner_ay:g} m/s^2 "
                       f"in the linear range; needs >= {need:g} s and >= {s.min_blocks} blocks")
    A, c = np.concatenate(XtX), np.concatenate(Xty)
    k = float(solve(A.sum(0), c.sum(0))[0])
    sd = robust_std(bootstrap(A, c, s.n_boot, s.seed)[:, 0])
    if not (k > 0 and sd <= s.max_rel_std * k):
        return refused("roll_gain", "rad/(m/s^2)",
                       f"roll gain {k:.3g} +- {sd:.2g} rad/(m/s^2) is not a positive, well-determined body roll: "
                       f"the reference roll is dominated by bank that changes with the cornering "
                       f"(superelevated curves) or by noise; needs cornering on flat or crowned roads")
    return Quantity("roll_gain", k, sd, "rad/(m/s^2)",
                    f"reference roll against vx r ({cornering:.0f} s of cornering), bank assumed uncorrelated "
                    f"with cornering; block bootstrap")
