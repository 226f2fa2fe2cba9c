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
"""
from __future__ import annotations

import numpy as np

from .. import units
from ..params import FLOATS, nonneg, positive, with_aliases
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
    )

    def prior_sigma(self, cfg):
        return units.arcmin(cfg.init_att_sigma_arcmin)

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
