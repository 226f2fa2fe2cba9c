"""Navigation blocks: attitude, velocity, position errors (frame axes x).

  att  phi_x, rad        C_b_x,est = (I - [phi x]) C_b_x,true
  vel  dv_x, m/s         (ENU: velocity w.r.t. Earth; LCI: inertial velocity)
  pos  dr_x, m           (ENU: local east/north/up metres; LCI: LCI metres)

Their coupled 9 x 9 dynamics are the strapdown error equations of the
mechanization frame (``core.frames``: ENU phi-angle model, LCI seed 001
eqs. 79-86); here they own their priors and the IMU white noises: the gyro
angle random walk enters the attitude error rate as -C_b_x w_g, the
accelerometer velocity random walk the velocity error rate as +C_b_x w_a.
Both are per body axis (a single number in a file means every axis) and may
be given in the units other tools use (``core.params`` aliases): ARW also in
rad/sqrt(s), deg/h/sqrt(Hz) or deg/s/sqrt(Hz) (MEMS data sheets), VRW also in m/s/sqrt(h) (KF-GINS) or
m/s/sqrt(s).

The attitude block also owns the gyro's rate-proportional errors when no
scale-factor / misalignment states are carried (``gyro_rate_error_pct``):
a MEMS gyro's scale-factor tolerance and cross-axis sensitivity (TDK
ICM-426xx class: +/-0.5 % and +/-1.25 % of the rate) make an error
delta_w = S w with S an unknown matrix. A handheld unit turns by tens of
degrees per second for a second or two at a time, so that error is not the
bias instability (which the bias blocks carry) and not the ARW: it is
treated as white over the turn, with the correlation time tau of the
turn's half duration (a turn of angle psi over T seconds then adds
sigma^2 psi^2 2 tau / T = sigma^2 psi^2 to the attitude variance, what the
constant S gives for one turn):

    Q_att += 2 sigma^2 |w|^2 tau dt I3      (isotropic in body axes, so in any frame)

with sigma = gyro_rate_error_pct / 100 and w the measured body rate of the
interval (``rate_error_q``; Groves 2nd ed. sec. 4.4.2 and 14.2.6 for the
error sources, the white-noise equivalent as in 14.2.6).
"""
from __future__ import annotations

import numpy as np

from .. import units
from ..params import FLOAT, FLOATS, nonneg, positive, with_aliases
from .base import Block, NoiseInput


class Attitude(Block):
    name, size, nav = "att", 3, True
    description = "attitude error phi, frame axes, rad"
    PARAMS = (
        with_aliases(positive("init_att_sigma_arcmin", FLOATS, (1.0, 1.0, 1.0),
                              "initial attitude 1-sigma per axis (arcmin)", length=3),
                     ("init_att_sigma_deg", 60.0, "deg")),
        with_aliases(nonneg("gyro_arw_deg_per_sqrt_hr", FLOATS, (0.01, 0.01, 0.01),
                            "gyro angle random walk the filter assumes, per body axis (deg/sqrt(h))", length=3),
                     ("gyro_arw_rad_per_sqrt_s", 1.0 / float(units.deg_per_sqrt_hr(1.0)), "rad/sqrt(s)"),
                     ("gyro_arw_deg_per_hr_per_sqrt_hz", 1.0 / 60.0, "deg/h/sqrt(Hz)"),
                     ("gyro_arw_deg_per_s_per_sqrt_hz", 60.0, "deg/s/sqrt(Hz), MEMS data sheets")),
        nonneg("gyro_rate_error_pct", FLOAT, 0.0,
               "1-sigma gyro scale-factor + cross-axis error, % of the body rate, as rate-proportional attitude "
               "noise (0: none; see core.blocks.nav)"),
        positive("gyro_rate_error_tau_s", FLOAT, 1.0,
                 "correlation time of the rate-proportional gyro error (s): half a turn's duration"),
    )

    def prior_sigma(self, cfg):
        return units.arcmin(cfg.init_att_sigma_arcmin)

    @staticmethod
    def rate_error_q(cfg, dtheta_b_rad, dt_s: float) -> float:
        """Variance (rad^2, per axis, isotropic) the rate-proportional gyro
        error adds to the attitude over one interval with body increment
        ``dtheta_b_rad`` (module docstring): 2 sigma^2 |dtheta|^2 tau / dt."""
        pct = cfg.gyro_rate_error_pct
        if pct <= 0.0 or dt_s <= 0.0:
            return 0.0
        d = dtheta_b_rad
        return 2.0 * (pct * 0.01) ** 2 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * cfg.gyro_rate_error_tau_s / dt_s

    def noise(self, cfg):
        arw = units.deg_per_sqrt_hr(cfg.gyro_arw_deg_per_sqrt_hr)
        return (NoiseInput("w_g", arw**2, "att", -np.eye(3), via_body=True),)


class Velocity(Block):
    name, size, nav = "vel", 3, True
    description = "velocity error, frame axes, m/s"
    PARAMS = (
        positive("init_vel_sigma_mps", FLOATS, (0.2, 0.2, 0.2), "initial velocity 1-sigma per axis (m/s)", length=3),
        with_aliases(nonneg("accel_vrw_ug_per_sqrt_hz", FLOATS, (100.0, 100.0, 100.0),
                            "accelerometer velocity random walk the filter assumes, per body axis (ug/sqrt(Hz))",
                            length=3),
                     ("accel_vrw_mps_per_sqrt_hr", 1.0 / float(units.ug_per_sqrt_hz(1.0)) / 60.0, "m/s/sqrt(h)"),
                     ("accel_vrw_mps_per_sqrt_s", 1.0 / float(units.ug_per_sqrt_hz(1.0)), "m/s/sqrt(s)")),
    )

    def prior_sigma(self, cfg):
        return np.asarray(cfg.init_vel_sigma_mps, float)

    def noise(self, cfg):
        vrw = units.ug_per_sqrt_hz(cfg.accel_vrw_ug_per_sqrt_hz)
        return (NoiseInput("w_a", vrw**2, "vel", np.eye(3), via_body=True),)


class Position(Block):
    name, size, nav = "pos", 3, True
    description = "position error, frame axes, m"
    PARAMS = (
        positive("init_pos_sigma_m", FLOATS, (5.0, 5.0, 10.0), "initial position 1-sigma per axis (m)", length=3),
    )

    def prior_sigma(self, cfg):
        return np.asarray(cfg.init_pos_sigma_m, float)
