"""The default's targets on real data, stated once: what ``roadbank validate`` and ``roadbank bench`` report.

The project's targets for the default estimator on real roads (:data:`roadbank.defaults.ESTIMATOR`),
each judged on data no choice looked at, raw RMS in deg:

* **KITTI validation drives** (:data:`roadbank.validation.splits.KITTI_VALIDATION`, no vehicle file, INS roll as
  reference): the default's median raw RMS is the lowest of every causal estimator that reads the log
  (``kinematic-lp``, the baseline to beat, included; the offline smoothers are not causal), and the default is
  below the raw kinematic estimate on at least :data:`BELOW_KINEMATIC_SHARE` of the drives. The drives carry a roll
  rate (the INS's), on which the default is the gyro-aided filter; the first target is also stated for the default
  without it (:data:`~roadbank.validation.scoring.ESP_DEFAULT`, the ESP channels alone), where it was first set.
* **comma2k19** (smoothed scores, offset fitted: :mod:`roadbank.validation.comma2k19`): r at least the kinematic
  estimate's (:data:`COMMA_R_FLOOR` is accepted where the raw RMS falls below the kinematic estimate's: the raw
  error is what a user gets), smoothed RMS at most :data:`COMMA_RMS_DEG`, and no lag shift: the lag that
  maximises r no longer than the kinematic estimate's (which has no filter).

The simulated target (car known) is :func:`roadbank.tuning.simulated.sim_targets` (``roadbank validate sim`` states
the same verdicts in its own words), the campaign's :func:`roadbank.campaign.report.default_target`; each is a
:class:`~roadbank.evaluation.targets.Target`.
"""

from __future__ import annotations

import math

from ..defaults import ESTIMATOR as DEFAULT
from ..estimators import NAMES, OFFLINE
from ..evaluation.targets import Target
from ..vehicle.factory import FITTED, NOT_FITTED
from .kitti import below_kinematic
from .scoring import ESP_DEFAULT

#: share of the KITTI validation drives on which the default must be below the raw kinematic estimate (-)
BELOW_KINEMATIC_SHARE = 0.9
#: the causal estimators the default is compared with (every estimator but the offline smoothers)
CAUSAL = tuple(n for n in NAMES if n not in OFFLINE)
#: comma2k19: largest smoothed RMS (deg), and the r accepted where the raw RMS falls (-)
COMMA_RMS_DEG, COMMA_R_FLOOR = 0.11, 0.92


def kitti_targets(v) -> list[Target]:
    """The KITTI targets on the validation drives of ``v`` (:class:`~roadbank.validation.kitti.KittiValidation`);
    none when ``v`` has no validation drive or did not run the default and the kinematic estimate, and the "lowest"
    one only when every causal estimator ran (it compares the default with all of them). ``data`` says whether the
    drives were designed without a vehicle file, as the target is stated."""
    part = v.by_split.get("validation")
    med = (part or {}).get("median_rms_raw_deg", {})
    if DEFAULT not in med or "kinematic" not in med:
        return []
    drives = [d for d in v.drives if d.label in part["drives"]]
    undescribed = all(d.data.get("design", {}).get("car_from") in (FITTED, NOT_FITTED) for d in drives)
    data = f"KITTI validation drives ({len(drives)}), " + ("no vehicle file" if undescribed else "car given")
    below, scored = below_kinematic(drives, DEFAULT)
    out = []
    if set(CAUSAL) <= set(med):
        others = {n: m for n, m in med.items() if n in CAUSAL and n != DEFAULT and math.isfinite(m)}
        best = min(others, key=others.__getitem__)
        out.append(Target(data, "the default's median raw RMS the lowest of every causal estimator",
                          f"{med[DEFAULT]:.5f} deg; lowest other: {best} {others[best]:.5f}",
                          med[DEFAULT] <= others[best]))
        if ESP_DEFAULT in med:          # the logs carry a roll rate: the same target on the ESP channels alone
            out.append(Target(data, "the same, the default without the roll rate (the ESP channels alone)",
                              f"{med[ESP_DEFAULT]:.5f} deg; lowest other: {best} {others[best]:.5f}",
                              med[ESP_DEFAULT] <= others[best]))
    out.append(Target(data, f"below the raw kinematic estimate on >= {100 * BELOW_KINEMATIC_SHARE:.0f} % of the drives",
                      f"{below} of {scored} ({100 * below / scored:.0f} %)" if scored else "no drive scored",
                      scored > 0 and below >= BELOW_KINEMATIC_SHARE * scored))
    return out


def comma_targets(res) -> list[Target]:
    """The comma2k19 targets of ``res`` (:class:`~roadbank.validation.comma2k19.ValidationResult`); none when it
    did not run the default and the kinematic estimate."""
    d, k = res.scores.get(DEFAULT), res.scores.get("kinematic")
    if d is None or k is None:
        return []
    data = "comma2k19 segment"
    raw_falls = d.rms_raw_deg < k.rms_raw_deg
    return [Target(data, f"r >= the kinematic estimate's ({COMMA_R_FLOOR:g} accepted where the raw RMS falls)",
                   f"r {d.r:.3f} against {k.r:.3f}; raw RMS {d.rms_raw_deg:.3f} against {k.rms_raw_deg:.3f} deg",
                   d.r >= k.r or (raw_falls and d.r >= COMMA_R_FLOOR)),
            Target(data, f"smoothed RMS <= {COMMA_RMS_DEG:g} deg", f"{d.rms_deg:.3f} deg", d.rms_deg <= COMMA_RMS_DEG),
            Target(data, "no lag shift: the lag that maximises r at most the kinematic estimate's",
                   f"{d.best_lag_s:+.2f} s against {k.best_lag_s:+.2f} s", d.best_lag_s <= k.best_lag_s)]

