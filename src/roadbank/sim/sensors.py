"""ESP sensor cluster: yaw rate, lateral acceleration, wheel-speed vx, steering-wheel angle.

Each channel is sampled from the integrated truth at ``rate`` (100 Hz default),
delayed by ``latency`` (rounded to the integration step), and corrupted in this
order: misalignment (ay only) -> scale error -> bias -> white Gaussian noise ->
range clipping -> quantisation to the resolution. Whole samples (CAN frames) can
be dropped with probability ``dropout_prob``; dropped samples are NaN (the
estimators hold their output there). All randomness comes from
``numpy.random.default_rng(seed)`` in a fixed order, so a seed reproduces a run
bit for bit.

Defaults follow the paper's ESP sensors (``roadbank.params.ESP_*``): yaw-rate range +-100 deg/s,
resolution 0.3 deg/s; lateral accelerometer +-1.8 g, resolution 0.005 g. Speed is the mean
of the two (undriven) rear wheel speeds times the wheel radius.

Misalignment: the paper's "ay = ay_real cos(10 deg)" is ``ay_misalignment =
radians(10)``; with ``ay_cross_axis=True`` the tilted sensor also picks up
``ax sin(angle)`` (a yaw-misaligned sensor), which the paper's condition omits.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..params import (ESP_AY_NOISE, ESP_AY_RANGE, ESP_AY_RESOLUTION, ESP_R_NOISE, ESP_R_RANGE, ESP_R_RESOLUTION,
                      ESP_RATE, ESP_SPEED_NOISE, ESP_SPEED_RESOLUTION, ESP_STEERING_NOISE, ESP_STEERING_RANGE,
                      ESP_STEERING_RESOLUTION)


@dataclass(frozen=True)
class ChannelErrorModel:
    """Error model of one sensor channel (SI units of the channel).

    noise_std : white-noise standard deviation; bias : constant offset;
    scale_error : relative gain error (0.01 = +1 %); resolution : quantisation
    step (0 = none); range : saturation magnitude (inf = none).
    """

    noise_std: float = 0.0
    bias: float = 0.0
    scale_error: float = 0.0
    resolution: float = 0.0
    range: float = math.inf

    def __post_init__(self) -> None:
        if self.noise_std < 0 or self.resolution < 0 or not self.range > 0:
            raise ValueError("ChannelErrorModel: noise_std, resolution must be >= 0 and range > 0")

    def apply(self, x: np.ndarray, noise: np.ndarray) -> np.ndarray:
        y = x * (1.0 + self.scale_error) + self.bias + self.noise_std * noise
        if math.isfinite(self.range):
            y = np.clip(y, -self.range, self.range)
        if self.resolution > 0:
            y = self.resolution * np.round(y / self.resolution)
        return y


@dataclass(frozen=True)
class SensorConfig:
    """Sensor cluster configuration (see the module docstring)."""

    rate: float = ESP_RATE
    latency: float = 0.0
    dropout_prob: float = 0.0
    yaw_rate: ChannelErrorModel = field(default_factory=lambda: ChannelErrorModel(
        noise_std=ESP_R_NOISE, resolution=ESP_R_RESOLUTION, range=ESP_R_RANGE))
    ay: ChannelErrorModel = field(default_factory=lambda: ChannelErrorModel(
        noise_std=ESP_AY_NOISE, resolution=ESP_AY_RESOLUTION, range=ESP_AY_RANGE))
    speed: ChannelErrorModel = field(default_factory=lambda: ChannelErrorModel(
        noise_std=ESP_SPEED_NOISE, resolution=ESP_SPEED_RESOLUTION))
    steering: ChannelErrorModel = field(default_factory=lambda: ChannelErrorModel(
        noise_std=ESP_STEERING_NOISE, resolution=ESP_STEERING_RESOLUTION, range=ESP_STEERING_RANGE))
    ay_misalignment: float = 0.0
    ay_cross_axis: bool = False
    #: a roll-rate gyro (the rate of bank + body roll about the forward axis, rad/s), None: none (an ESP
    #: cluster has none). Its noise is drawn after every other channel's, so adding it changes no other channel.
    roll_rate: ChannelErrorModel | None = None

    def __post_init__(self) -> None:
        if not (self.rate > 0 and math.isfinite(self.rate)):
            raise ValueError("SensorConfig.rate must be > 0")
        if not self.latency >= 0:
            raise ValueError("SensorConfig.latency must be >= 0")
        if not 0.0 <= self.dropout_prob < 1.0:
            raise ValueError("SensorConfig.dropout_prob must be in [0, 1)")

    def replace(self, **changes) -> "SensorConfig":
        return dataclasses.replace(self, **changes)

    @classmethod
    def ideal(cls, rate: float = 100.0) -> "SensorConfig":
        """Perfect sensors (no noise, quantisation, range or misalignment)."""
        c = ChannelErrorModel()
        return cls(rate=rate, yaw_rate=c, ay=c, speed=c, steering=c)


def measure(truth: dict, config: SensorConfig, rng: np.random.Generator) -> dict:
    """Apply the sensor models to true channel values sampled at the sensor instants.

    Parameters
    ----------
    truth : dict of arrays
        ``r`` (rad/s), ``ay``, ``ax`` (m/s^2, specific force), ``v_wheels``
        (m/s, rear wheel-speed mean), ``swa`` (rad), already delayed by the latency; ``p``
        (rad/s, roll rate) with a roll-rate gyro (``config.roll_rate``).

    Returns
    -------
    dict with ``r, ay, vx, swa`` (measured, NaN where dropped), and ``p`` with a roll-rate gyro.
    """
    n = len(truth["r"])
    noise = rng.standard_normal((4, n))
    m = config.ay_misalignment
    ay = truth["ay"] * math.cos(m)
    if config.ay_cross_axis:
        ay = ay + truth["ax"] * math.sin(m)
    out = {
        "r": config.yaw_rate.apply(truth["r"], noise[0]),
        "ay": config.ay.apply(ay, noise[1]),
        "vx": config.speed.apply(truth["v_wheels"], noise[2]),
        "swa": config.steering.apply(truth["swa"], noise[3]),
    }
    if config.dropout_prob > 0:
        drop = rng.random(n) < config.dropout_prob
        for k in out:
            out[k] = np.where(drop, np.nan, out[k])
    if config.roll_rate is not None:            # drawn last: the other channels are those of a cluster without it
        p = config.roll_rate.apply(truth["p"], rng.standard_normal(n))
        out["p"] = np.where(drop, np.nan, p) if config.dropout_prob > 0 else p
    return out
