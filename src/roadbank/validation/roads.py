"""A real drive as a smooth road: what a quiet log of the same car, driven the same way, would read.

Every real drive the project has reads loud (a 10 Hz INS sampling road vibration without an anti-alias filter), so the
default's quiet branch would otherwise meet no real log. :func:`smooth_road` low-passes a drive's ``ay`` and yaw rate
without phase and adds the ESP data sheet's white noise; the reference roll, the speed and every other channel stay as
recorded. :data:`SMOOTH_ROADS` are the two forms the sixtieth to sixty-third stages of :mod:`roadbank.tuning.real` read
on the training drives: both read quiet there (0.48-1.11 and 0.71-1.45 times the data sheet's density).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.signal import butter, filtfilt, sosfiltfilt

from ..signals import Signals, sample_rate
from ..sim.sensors import SensorConfig

#: the smooth roads by label: (Butterworth order, cut-off Hz). The sixtieth stage's (second order, 0.5 Hz) and the
#: sixty-second's steep one (eighth order, 0.8 Hz: it keeps the car's motion up to about 0.7 Hz)
SMOOTH_ROADS = {"0.5 Hz": (2, 0.5), "0.8 Hz, steep": (8, 0.8)}


def smooth_road(s: Signals, order: int, cutoff: float, seed: int) -> Signals:
    """``s`` as the same drive on a smooth road read by a data sheet's sensors: ``ay`` (m/s^2) and the yaw rate
    (rad/s) through a zero-phase Butterworth low-pass of ``order`` at ``cutoff`` (Hz, at the drive's own rate; second
    order as transfer-function coefficients, as the sixtieth stage ran, a steeper one as second-order sections) plus
    the ESP data sheet's white noise (:class:`roadbank.sim.SensorConfig`; one numpy generator seeded ``seed``, ``ay``'s
    noise drawn first); every other channel as it is."""
    cfg = SensorConfig()
    rng = np.random.default_rng(seed)
    wn = cutoff / (0.5 * sample_rate(s.t))
    if order == 2:
        b, a = butter(order, wn)
        ay, r = filtfilt(b, a, s.ay), filtfilt(b, a, s.r)
    else:
        sos = butter(order, wn, output="sos")
        ay, r = sosfiltfilt(sos, s.ay), sosfiltfilt(sos, s.r)
    ay = ay + cfg.ay.noise_std * rng.standard_normal(len(s))
    r = r + cfg.yaw_rate.noise_std * rng.standard_normal(len(s))
    return dataclasses.replace(s, ay=ay, r=r)
