"""IMU error model: constant bias and white noise on the exact increments.

Datasheet units in, SI increments out (seed 000 section IV.B: gyro constant
drift 0.1 deg/h and white noise 0.01 deg/h, read as an angle random walk of
0.01 deg/sqrt(h); accelerometer bias 1e-3 g, white noise 1e-4 g read as
100 ug/sqrt(Hz)). Noise per increment: ARW * sqrt(dt), VRW * sqrt(dt).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core import units


@dataclass(frozen=True)
class ImuErrors:
    gyro_bias_b_radps: np.ndarray
    gyro_arw_rad_per_sqrt_s: float
    accel_bias_b_mps2: np.ndarray
    accel_vrw_mps_per_sqrt_s: float

    @classmethod
    def from_scenario(cls, sc) -> "ImuErrors":
        return cls(units.deg_per_hr(sc["imu.gyro_bias_deg_per_hr"]),
                   float(units.deg_per_sqrt_hr(sc["imu.gyro_arw_deg_per_sqrt_hr"])),
                   units.ug(sc["imu.accel_bias_ug"]),
                   float(units.ug_per_sqrt_hz(sc["imu.accel_vrw_ug_per_sqrt_hz"])))


def corrupt_increments(dtheta_b_rad, dvel_b_mps, dt_s, errors: ImuErrors, rng: np.random.Generator):
    """Add bias and white noise to exact increments (arrays (N, 3))."""
    n = dtheta_b_rad.shape[0]
    dth = (dtheta_b_rad + errors.gyro_bias_b_radps * dt_s
           + rng.standard_normal((n, 3)) * errors.gyro_arw_rad_per_sqrt_s * np.sqrt(dt_s))
    dv = (dvel_b_mps + errors.accel_bias_b_mps2 * dt_s
          + rng.standard_normal((n, 3)) * errors.accel_vrw_mps_per_sqrt_s * np.sqrt(dt_s))
    return dth, dv


def imu_epochs(duration_s: float, rate_hz: float) -> np.ndarray:
    """IMU epochs (end of each interval) from 1/rate to duration, on sim time."""
    n = int(np.floor(duration_s * rate_hz + 1e-9))
    return np.arange(1, n + 1) / rate_hz
