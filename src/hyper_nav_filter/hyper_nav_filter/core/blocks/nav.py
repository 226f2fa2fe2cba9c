"""Navigation blocks: attitude, velocity, position errors (frame axes x).

  att  phi_x, rad        C_b_x,est = (I - [phi x]) C_b_x,true
  vel  dv_x, m/s         (ENU: velocity w.r.t. Earth; LCI: inertial velocity)
  pos  dr_x, m           (ENU: local east/north/up metres; LCI: LCI metres)

Their coupled 9 x 9 dynamics are the strapdown error equations of the
mechanization frame (``core.frames``: ENU phi-angle model, LCI seed 001
eqs. 79-86); here they own their priors and the IMU white noises: the gyro
angle random walk enters the attitude error rate as -C_b_x w_g, the
accelerometer velocity random walk the velocity error rate as +C_b_x w_a.
"""
from __future__ import annotations

import numpy as np

from .. import units
from ..params import FLOAT, FLOATS, nonneg, positive
from .base import Block, NoiseInput


class Attitude(Block):
    name, size, nav = "att", 3, True
    description = "attitude error phi, frame axes, rad"
    PARAMS = (
        positive("init_att_sigma_arcmin", FLOATS, (1.0, 1.0, 1.0), "initial attitude 1-sigma per axis (arcmin)",
                 length=3),
        nonneg("gyro_arw_deg_per_sqrt_hr", FLOAT, 0.01, "gyro angle random walk the filter assumes (deg/sqrt(h))"),
    )

    def prior_sigma(self, cfg):
        return units.arcmin(cfg.init_att_sigma_arcmin)

    def noise(self, cfg):
        arw = float(units.deg_per_sqrt_hr(cfg.gyro_arw_deg_per_sqrt_hr))
        return (NoiseInput("w_g", np.full(3, arw**2), "att", -np.eye(3), via_body=True),)


class Velocity(Block):
    name, size, nav = "vel", 3, True
    description = "velocity error, frame axes, m/s"
    PARAMS = (
        positive("init_vel_sigma_mps", FLOATS, (0.2, 0.2, 0.2), "initial velocity 1-sigma per axis (m/s)", length=3),
        nonneg("accel_vrw_ug_per_sqrt_hz", FLOAT, 100.0,
               "accelerometer velocity random walk the filter assumes (ug/sqrt(Hz))"),
    )

    def prior_sigma(self, cfg):
        return np.asarray(cfg.init_vel_sigma_mps, float)

    def noise(self, cfg):
        vrw = float(units.ug_per_sqrt_hz(cfg.accel_vrw_ug_per_sqrt_hz))
        return (NoiseInput("w_a", np.full(3, vrw**2), "vel", np.eye(3), via_body=True),)


class Position(Block):
    name, size, nav = "pos", 3, True
    description = "position error, frame axes, m"
    PARAMS = (
        positive("init_pos_sigma_m", FLOATS, (5.0, 5.0, 10.0), "initial position 1-sigma per axis (m)", length=3),
    )

    def prior_sigma(self, cfg):
        return np.asarray(cfg.init_pos_sigma_m, float)
