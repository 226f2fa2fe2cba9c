"""IMU sensor-error blocks, all in body axes (estimate minus truth).

  bg  gyro bias, rad/s                 first-order Gauss-Markov (tau -> inf: random constant)
  ba  accelerometer bias, m/s^2        first-order Gauss-Markov
  gm  first-order Markov gyro drift, rad/s (seed 000 eqs. 14-15: gm' = -gm / T_g + w_gm);
      the nominal drift decays between updates as its model says
  sg  gyro scale factor, dimensionless    (omega_meas = (1 + sg) omega + bg), random constant
  sa  accelerometer scale factor          (f_meas = (1 + sa) f + ba), random constant

Coupling into any frame x (C = C_b_x; w, f the compensated body rate and
specific force):
  phi_dot += C d_bg + C d_gm + C diag(w) d_sg,   dv_dot += -C d_ba - C diag(f) d_sa.
"""
from __future__ import annotations

import numpy as np

from .. import units
from ..params import FLOAT, positive
from .base import Block, BodyCoupling, NoiseInput, gauss_markov_psd

I3 = np.eye(3)


class _GaussMarkov(Block):
    """A body 3-vector error, first-order Gauss-Markov with sigma and tau."""
    size = 3
    target = "att"
    sign = 1.0
    sigma_field = tau_field = ""

    def _sigma_si(self, cfg):
        raise NotImplementedError

    def prior_sigma(self, cfg):
        return np.full(3, self._sigma_si(cfg))

    def self_dynamics(self, cfg):
        return -I3 / getattr(cfg, self.tau_field)

    def couplings(self, cfg):
        return (BodyCoupling(self.target, const=self.sign * I3),)

    def noise(self, cfg):
        psd = gauss_markov_psd(np.full(3, self._sigma_si(cfg)), getattr(cfg, self.tau_field))
        return (NoiseInput(f"w_{self.name}", psd, "self", I3),)


class GyroBias(_GaussMarkov):
    name, imu_role, target = "bg", "gyro_bias", "att"
    description = "gyro bias error, body, rad/s"
    nav_state_field = "gyro_bias_b_radps"
    tau_field = "gyro_bias_tau_s"
    PARAMS = (
        positive("gyro_bias_sigma_deg_per_hr", FLOAT, 0.1, "gyro bias 1-sigma (deg/h): prior and steady state"),
        positive("gyro_bias_tau_s", FLOAT, 3600.0, "gyro bias correlation time (s); very large = random constant"),
    )

    def _sigma_si(self, cfg):
        return float(units.deg_per_hr(cfg.gyro_bias_sigma_deg_per_hr))


class AccelBias(_GaussMarkov):
    name, imu_role, target, sign = "ba", "accel_bias", "vel", -1.0
    description = "accelerometer bias error, body, m/s^2"
    nav_state_field = "accel_bias_b_mps2"
    tau_field = "accel_bias_tau_s"
    PARAMS = (
        positive("accel_bias_sigma_ug", FLOAT, 1000.0, "accelerometer bias 1-sigma (ug): prior and steady state"),
        positive("accel_bias_tau_s", FLOAT, 3600.0, "accelerometer bias correlation time (s)"),
    )

    def _sigma_si(self, cfg):
        return float(units.ug(cfg.accel_bias_sigma_ug))


class GyroMarkov(_GaussMarkov):
    name, imu_role, target = "gm", "gyro_bias", "att"
    description = "first-order Markov gyro drift error, body, rad/s (seed 000 eqs. 14-15)"
    tau_field = "gyro_markov_tau_s"
    PARAMS = (
        positive("gyro_markov_sigma_deg_per_hr", FLOAT, 0.05, "Markov gyro drift 1-sigma (deg/h)"),
        positive("gyro_markov_tau_s", FLOAT, 300.0, "Markov gyro drift correlation time T_g (s)"),
    )

    def _sigma_si(self, cfg):
        return float(units.deg_per_hr(cfg.gyro_markov_sigma_deg_per_hr))

    def propagate(self, value, dt_s, cfg):
        return value * np.exp(-dt_s / cfg.gyro_markov_tau_s)


class GyroScaleFactor(Block):
    name, size, imu_role = "sg", 3, "gyro_scale"
    description = "gyro scale-factor error, body, dimensionless"
    PARAMS = (positive("gyro_scale_factor_sigma_ppm", FLOAT, 100.0, "gyro scale factor 1-sigma (ppm), random constant"),)

    def prior_sigma(self, cfg):
        return np.full(3, cfg.gyro_scale_factor_sigma_ppm * 1e-6)

    def couplings(self, cfg):
        return (BodyCoupling("att", diag_w=I3),)


class AccelScaleFactor(Block):
    name, size, imu_role = "sa", 3, "accel_scale"
    description = "accelerometer scale-factor error, body, dimensionless"
    PARAMS = (positive("accel_scale_factor_sigma_ppm", FLOAT, 100.0,
                       "accelerometer scale factor 1-sigma (ppm), random constant"),)

    def prior_sigma(self, cfg):
        return np.full(3, cfg.accel_scale_factor_sigma_ppm * 1e-6)

    def couplings(self, cfg):
        return (BodyCoupling("vel", diag_f=-I3),)
