"""A car's ESP sensor cluster (:class:`SensorSpec`): rate, noise, resolution, range, bias (SI)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ..params import (ESP_AY_NOISE, ESP_AY_RANGE, ESP_AY_RESOLUTION, ESP_R_NOISE, ESP_R_RANGE, ESP_R_RESOLUTION,
                      ESP_RATE, ESP_SPEED_NOISE, ESP_SPEED_RESOLUTION, ESP_STEERING_NOISE, ESP_STEERING_RANGE,
                      ESP_STEERING_RESOLUTION)

# roadbank.estimators and roadbank.sim (numba) are imported inside the functions that use
# them: loading a car (load_vehicle, --vehicle) loads neither

__all__ = ["SensorSpec"]


@dataclass(frozen=True)
class SensorSpec:
    """A car's ESP sensor cluster (SI). Defaults: the paper's ESP sensors (``roadbank.params.ESP_*``,
    also those of ``SensorConfig()``).

    Parameters
    ----------
    rate : float
        Sample rate (Hz), 100.
    latency : float
        Delay of every channel (s), 0.
    dropout_prob : float
        Probability that a sample (CAN frame) is lost (-), 0.
    ay_noise, ay_resolution, ay_range, ay_bias : float
        Lateral accelerometer: white-noise std, quantisation step, saturation, offset
        (m/s^2): 0.03, 0.005 g, 1.8 g, 0.
    ay_misalignment : float
        Mounting angle of the accelerometer (rad), 0: it reads ``ay cos(angle)``.
    r_noise, r_resolution, r_range, r_bias : float
        Yaw-rate sensor (rad/s): 0.1 deg/s, 0.3 deg/s, 100 deg/s, 0.
    speed_noise, speed_resolution : float
        Wheel-speed vehicle speed (m/s): 0.02, 0.01.
    steering_noise, steering_resolution, steering_range : float
        Steering-wheel angle sensor (rad): 0, 0.1 deg, 780 deg.
    """

    rate: float = ESP_RATE
    latency: float = 0.0
    dropout_prob: float = 0.0
    ay_noise: float = ESP_AY_NOISE
    ay_resolution: float = ESP_AY_RESOLUTION
    ay_range: float = ESP_AY_RANGE
    ay_bias: float = 0.0
    ay_misalignment: float = 0.0
    r_noise: float = ESP_R_NOISE
    r_resolution: float = ESP_R_RESOLUTION
    r_range: float = ESP_R_RANGE
    r_bias: float = 0.0
    speed_noise: float = ESP_SPEED_NOISE
    speed_resolution: float = ESP_SPEED_RESOLUTION
    steering_noise: float = ESP_STEERING_NOISE
    steering_resolution: float = ESP_STEERING_RESOLUTION
    steering_range: float = ESP_STEERING_RANGE

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise ValueError(f"SensorSpec.{f.name} must be a finite number, got {v!r}")
        if not self.rate > 0:
            raise ValueError(f"SensorSpec.rate must be > 0 Hz, got {self.rate}")
        for name in ("latency", "ay_noise", "ay_resolution", "r_noise", "r_resolution", "speed_noise",
                     "speed_resolution", "steering_noise", "steering_resolution"):
            if getattr(self, name) < 0:
                raise ValueError(f"SensorSpec.{name} must be >= 0, got {getattr(self, name)}")
        for name in ("ay_range", "r_range", "steering_range"):
            if not getattr(self, name) > 0:
                raise ValueError(f"SensorSpec.{name} must be > 0, got {getattr(self, name)}")
        if not 0.0 <= self.dropout_prob < 1.0:
            raise ValueError(f"SensorSpec.dropout_prob must be in [0, 1), got {self.dropout_prob}")

    @property
    def r_variance(self) -> float:
        """Yaw-rate measurement variance, noise + uniform quantisation: ``r_noise^2 + r_resolution^2/12``
        ((rad/s)^2)."""
        return self.r_noise ** 2 + self.r_resolution ** 2 / 12.0

    def rate_for(self, rate: float | None = None) -> float:
        """``rate`` (Hz) when it is a positive finite number, else the sensor's own ``rate``."""
        return rate if rate is not None and math.isfinite(rate) and rate > 0 else self.rate

    def r_noise_density(self, rate: float | None = None) -> float:
        """Yaw-rate noise density ``R`` ((rad/s)^2 s) of this sensor sampled at ``rate`` (Hz).

        ``r_variance / rate`` (:func:`roadbank.estimators.pif.yaw_rate_noise_density`): the
        same per-sample noise and quantisation stand for a density ten times larger at 10 Hz
        than at 100 Hz. ``rate`` None or not a positive finite number: the sensor's ``rate``.
        """
        from ..estimators.pif import yaw_rate_noise_density

        return yaw_rate_noise_density(self.r_noise, self.r_resolution, self.rate_for(rate))

    @property
    def ay_variance(self) -> float:
        """Lateral-acceleration measurement variance ``ay_noise^2 + ay_resolution^2/12`` ((m/s^2)^2)."""
        return self.ay_noise ** 2 + self.ay_resolution ** 2 / 12.0

    def ay_noise_density(self, rate: float | None = None) -> float:
        """Lateral-acceleration noise density ``Q_ay`` ((m/s^2)^2 s) of this sensor sampled at
        ``rate`` (Hz): ``ay_variance / rate``, as :meth:`r_noise_density`."""
        return self.ay_variance / self.rate_for(rate)

    @property
    def dt(self) -> float:
        """Sample period 1/rate (s)."""
        return 1.0 / self.rate

    def replace(self, **changes: float) -> "SensorSpec":
        """Copy with fields changed (validated)."""
        return dataclasses.replace(self, **changes)

    def to_sim(self, **changes):
        """The simulator's sensor model for this cluster.

        Parameters
        ----------
        **changes
            Fields of :class:`roadbank.sim.SensorConfig` to override (e.g. ``seed``-independent
            ``dropout_prob``).

        Returns
        -------
        roadbank.sim.sensors.SensorConfig
        """
        from ..sim.sensors import ChannelErrorModel, SensorConfig

        cfg = SensorConfig(
            rate=float(self.rate), latency=float(self.latency), dropout_prob=float(self.dropout_prob),
            yaw_rate=ChannelErrorModel(noise_std=self.r_noise, bias=self.r_bias, resolution=self.r_resolution,
                                 range=self.r_range),
            ay=ChannelErrorModel(noise_std=self.ay_noise, bias=self.ay_bias, resolution=self.ay_resolution,
                           range=self.ay_range),
            speed=ChannelErrorModel(noise_std=self.speed_noise, resolution=self.speed_resolution),
            steering=ChannelErrorModel(noise_std=self.steering_noise, resolution=self.steering_resolution,
                                 range=self.steering_range),
            ay_misalignment=float(self.ay_misalignment))
        return cfg.replace(**changes) if changes else cfg
