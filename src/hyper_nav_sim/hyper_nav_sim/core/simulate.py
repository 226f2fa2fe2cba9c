"""Offline simulation of every sensor stream of a scenario (no ROS).

The sensor nodes call the same functions for their own stream, so a live
graph and this offline run produce the same data for the same scenario.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .gnss_model import GnssFixes, simulate_fixes
from .imu_model import ImuErrors, corrupt_increments, imu_epochs
from .mag_model import simulate_magnetometer_T
from .scenario import Scenario


@dataclass
class ImuStream:
    t_s: np.ndarray
    dt_s: float
    dtheta_b_rad: np.ndarray
    dvel_b_mps: np.ndarray


def imu_stream(sc: Scenario, traj, error_free: bool = False) -> ImuStream:
    dt = 1.0 / sc["imu.rate_hz"]
    t = imu_epochs(sc["duration_s"], sc["imu.rate_hz"])
    dth, dv = traj.imu_increments(t, dt)
    if not error_free:
        dth, dv = corrupt_increments(dth, dv, dt, ImuErrors.from_scenario(sc), sc.rng("imu"))
    return ImuStream(t, dt, dth, dv)


def gnss_stream(sc: Scenario, traj) -> GnssFixes:
    t = imu_epochs(sc["duration_s"], sc["gnss.rate_hz"])
    return simulate_fixes(traj, t, sc["gnss.pos_sigma_enu_m"], sc["gnss.vel_sigma_enu_mps"],
                          sc["gnss.antenna_lever_arm_b_m"], sc.rng("gnss"))


def mag_stream(sc: Scenario, traj):
    t = imu_epochs(sc["duration_s"], sc["magnetometer.rate_hz"])
    return t, simulate_magnetometer_T(traj, t, sc["magnetometer.epoch_decimal_year"],
                                      sc["magnetometer.noise_nT"], sc.rng("mag"))
