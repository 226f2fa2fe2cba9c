"""IMU sensor-error blocks, all in body axes (estimate minus truth).

  bg  gyro bias, rad/s                 first-order Gauss-Markov (tau -> inf: random constant)
  ba  accelerometer bias, m/s^2        first-order Gauss-Markov
  gm  first-order Markov gyro drift, rad/s (seed 000 eqs. 14-15: gm' = -gm / T_g + w_gm);
      the nominal drift decays between updates as its model says
  sg  gyro scale factor, dimensionless    (omega_meas = (1 + sg) omega + bg)
  sa  accelerometer scale factor          (f_meas = (1 + sa) f + ba)
      random constants, or first-order Gauss-Markov with ``*_scale_factor_tau_s``
      (KF-GINS models them so)

Coupling into any frame x (C = C_b_x; w, f the compensated body rate and
specific force):
  phi_dot += C d_bg + C d_gm + C diag(w) d_sg,   dv_dot += -C d_ba - C diag(f) d_sa.

Every sigma is per body axis (one number in a file means every axis). The
steady-state sigma of a Gauss-Markov block sets its driving noise
(2 sigma^2 / tau); its prior (initial 1-sigma) is the ``init_*_sigma``
parameter when that is set, else the steady-state sigma. Units other tools
use are aliases (``core.params``): accelerometer biases in mGal or m/s^2,
gyro biases in rad/s or deg/s (MEMS). A data sheet's bias random walk N_b
(e.g. ug/sqrt(Hz), deg/s/sqrt(s)) is this model with a correlation time tau
longer than the run and sigma = N_b sqrt(tau / 2): the driving noise
2 sigma^2 / tau is then N_b^2 (Groves 2nd ed. sec. 14.2.6). Initial values of biases and scale factors come with
the initial state (``core.initial_state``), not from here.
"""
from __future__ import annotations

import math

import numpy as np

from .. import units
from ..params import FLOAT, FLOATS, ParamSpec, positive, with_aliases
from .base import Block, BodyCoupling, NoiseInput, gauss_markov_psd

I3 = np.eye(3)
_MGAL_IN_UG = 1e-5 / float(units.ug(1.0))            # 1 mGal = 1e-5 m/s^2 = 1.0197 ug
_RADPS_IN_DPH = 1.0 / float(units.deg_per_hr(1.0))


def _sigma3(name, default, what, unit, *aliases):
    return with_aliases(positive(name, FLOATS, (default,) * 3, f"{what}, per body axis ({unit})", length=3),
                        *aliases)


def _init_sigma3(name, of, unit, *aliases):
    return with_aliases(ParamSpec(name, FLOATS, (math.nan,) * 3, f"initial 1-sigma per body axis ({unit}); "
                                  f"NaN (not set) = {of}", lo=0.0, lo_open=True, length=3, optional=True),
                        *aliases)


class _GaussMarkov(Block):
    """A body 3-vector error, first-order Gauss-Markov with sigma and tau
    (a random constant when the block has no tau or tau is NaN)."""
    size = 3
    target = "att"
    sign = 1.0
    sigma_field = tau_field = init_sigma_field = ""
    to_si = 1.0                                         # sigma unit -> SI

    def _sigma_si(self, cfg) -> np.ndarray:
        return np.asarray(getattr(cfg, self.sigma_field), float) * self.to_si

    def _tau_s(self, cfg) -> float:
        tau = getattr(cfg, self.tau_field) if self.tau_field else math.nan
        return math.nan if tau is None else float(tau)

    def prior_sigma(self, cfg):
        if self.init_sigma_field:
            init = np.asarray(getattr(cfg, self.init_sigma_field), float)
            if not np.all(np.isnan(init)):
                return init * self.to_si
        return self._sigma_si(cfg)

    def self_dynamics(self, cfg):
        tau = self._tau_s(cfg)
        return None if math.isnan(tau) else -I3 / tau

    def noise(self, cfg):
        tau = self._tau_s(cfg)
        if math.isnan(tau):
            return ()
        return (NoiseInput(f"w_{self.name}", gauss_markov_psd(self._sigma_si(cfg), tau), "self", I3),)


class _BiasBlock(_GaussMarkov):
    def couplings(self, cfg):
        return (BodyCoupling(self.target, const=self.sign * I3),)


class GyroBias(_BiasBlock):
    name, imu_role, target = "bg", "gyro_bias", "att"
    description = "gyro bias error, body, rad/s"
    nav_state_field = "gyro_bias_b_radps"
    sigma_field, tau_field, init_sigma_field = "gyro_bias_sigma_deg_per_hr", "gyro_bias_tau_s", \
        "init_gyro_bias_sigma_deg_per_hr"
    to_si = float(units.deg_per_hr(1.0))
    PARAMS = (
        _sigma3("gyro_bias_sigma_deg_per_hr", 0.1, "gyro bias steady-state 1-sigma (sets the driving noise)",
                "deg/h", ("gyro_bias_sigma_rad_per_s", _RADPS_IN_DPH, "rad/s"),
                ("gyro_bias_sigma_deg_per_s", 3600.0, "deg/s")),
        positive("gyro_bias_tau_s", FLOAT, 3600.0, "gyro bias correlation time (s); very large = random constant"),
        _init_sigma3("init_gyro_bias_sigma_deg_per_hr", "gyro_bias_sigma_deg_per_hr", "deg/h",
                     ("init_gyro_bias_sigma_rad_per_s", _RADPS_IN_DPH, "rad/s"),
                     ("init_gyro_bias_sigma_deg_per_s", 3600.0, "deg/s")),
    )


class AccelBias(_BiasBlock):
    name, imu_role, target, sign = "ba", "accel_bias", "vel", -1.0
    description = "accelerometer bias error, body, m/s^2"
    nav_state_field = "accel_bias_b_mps2"
    sigma_field, tau_field, init_sigma_field = "accel_bias_sigma_ug", "accel_bias_tau_s", "init_accel_bias_sigma_ug"
    to_si = float(units.ug(1.0))
    PARAMS = (
        _sigma3("accel_bias_sigma_ug", 1000.0, "accelerometer bias steady-state 1-sigma (sets the driving noise)",
                "ug", ("accel_bias_sigma_mgal", _MGAL_IN_UG, "mGal"),
                ("accel_bias_sigma_mps2", 1.0 / float(units.ug(1.0)), "m/s^2")),
        positive("accel_bias_tau_s", FLOAT, 3600.0, "accelerometer bias correlation time (s)"),
        _init_sigma3("init_accel_bias_sigma_ug", "accel_bias_sigma_ug", "ug",
                     ("init_accel_bias_sigma_mgal", _MGAL_IN_UG, "mGal"),
                     ("init_accel_bias_sigma_mps2", 1.0 / float(units.ug(1.0)), "m/s^2")),
    )


class GyroMarkov(_BiasBlock):
    name, imu_role, target = "gm", "gyro_bias", "att"
    description = "first-order Markov gyro drift error, body, rad/s (seed 000 eqs. 14-15)"
    sigma_field, tau_field = "gyro_markov_sigma_deg_per_hr", "gyro_markov_tau_s"
    to_si = float(units.deg_per_hr(1.0))
    PARAMS = (
        _sigma3("gyro_markov_sigma_deg_per_hr", 0.05, "Markov gyro drift 1-sigma", "deg/h"),
        positive("gyro_markov_tau_s", FLOAT, 300.0, "Markov gyro drift correlation time T_g (s)"),
    )

    def propagate(self, value, dt_s, cfg):
        return value * np.exp(-dt_s / cfg.gyro_markov_tau_s)


def _scale_tau(name, sensor):
    return ParamSpec(name, FLOAT, math.nan, f"{sensor} scale-factor correlation time (s): first-order Gauss-Markov; "
                     "NaN (not set) = random constant", lo=0.0, lo_open=True, optional=True)


class GyroScaleFactor(_GaussMarkov):
    name, size, imu_role = "sg", 3, "gyro_scale"
    description = "gyro scale-factor error, body, dimensionless"
    sigma_field, tau_field, init_sigma_field = "gyro_scale_factor_sigma_ppm", "gyro_scale_factor_tau_s", \
        "init_gyro_scale_factor_sigma_ppm"
    to_si = 1e-6
    PARAMS = (
        _sigma3("gyro_scale_factor_sigma_ppm", 100.0, "gyro scale factor 1-sigma (steady state when Gauss-Markov)",
                "ppm"),
        _scale_tau("gyro_scale_factor_tau_s", "gyro"),
        _init_sigma3("init_gyro_scale_factor_sigma_ppm", "gyro_scale_factor_sigma_ppm", "ppm"),
    )

    def couplings(self, cfg):
        return (BodyCoupling("att", diag_w=I3),)


class AccelScaleFactor(_GaussMarkov):
    name, size, imu_role = "sa", 3, "accel_scale"
    description = "accelerometer scale-factor error, body, dimensionless"
    sigma_field, tau_field, init_sigma_field = "accel_scale_factor_sigma_ppm", "accel_scale_factor_tau_s", \
        "init_accel_scale_factor_sigma_ppm"
    to_si = 1e-6
    PARAMS = (
        _sigma3("accel_scale_factor_sigma_ppm", 100.0,
                "accelerometer scale factor 1-sigma (steady state when Gauss-Markov)", "ppm"),
        _scale_tau("accel_scale_factor_tau_s", "accelerometer"),
        _init_sigma3("init_accel_scale_factor_sigma_ppm", "accel_scale_factor_sigma_ppm", "ppm"),
    )

    def couplings(self, cfg):
        return (BodyCoupling("vel", diag_f=-I3),)
