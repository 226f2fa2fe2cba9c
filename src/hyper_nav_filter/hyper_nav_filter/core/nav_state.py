"""Nominal navigation state and IMU sample types shared by the INS and filter."""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np


class ImuSample(NamedTuple):
    """IMU increments over (t_s - dt_s, t_s], body FLU axes.

    ``dtheta_b_rad`` is the integral of the angular rate omega_ib_b and
    ``dvel_b_mps`` the integral of specific force over the interval.
    (A NamedTuple: one is made per IMU epoch, at a fifth of a frozen
    dataclass's construction cost.)
    """
    t_s: float
    dt_s: float
    dtheta_b_rad: np.ndarray
    dvel_b_mps: np.ndarray
    # the specific force that loads the structure over the interval (body FLU, m/s^2): the mean (3,),
    # or the load sensor's means over the n equal sub-intervals (n, 3); the lever-arm-free force of the
    # external loads (seed 000 eqs. 4-6, the known input u_q of eq. 22), when a source gives it;
    # None: the lever-arm block takes the measured one (see blocks.lever_arm)
    load_f_b_mps2: np.ndarray | None = None


@dataclass
class NavState:
    """Nominal strapdown state in the local-level (ENU/geodetic) frame."""
    t_s: float
    lat_rad: float
    lon_rad: float
    alt_m: float
    vel_enu_mps: np.ndarray
    C_b_n: np.ndarray
    gyro_bias_b_radps: np.ndarray = field(default_factory=lambda: np.zeros(3))
    accel_bias_b_mps2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # nominal values of the optional blocks, e.g. {"gm": gyro Markov drift (rad/s),
    # "clk": [clock bias m, clock drift m/s], "sg"/"sa": gyro/accel scale factors}
    extra: dict = field(default_factory=dict)

    def copy(self) -> "NavState":
        return replace(self, vel_enu_mps=self.vel_enu_mps.copy(), C_b_n=self.C_b_n.copy(),
                       gyro_bias_b_radps=self.gyro_bias_b_radps.copy(),
                       accel_bias_b_mps2=self.accel_bias_b_mps2.copy(),
                       extra={k: v.copy() for k, v in self.extra.items()})

    def gyro_error_b_radps(self) -> np.ndarray:
        """Total estimated gyro error: constant bias plus Markov drift."""
        gm = self.extra.get("gm")
        return self.gyro_bias_b_radps if gm is None else self.gyro_bias_b_radps + gm

    def compensate(self, dtheta_b_rad: np.ndarray, dvel_b_mps: np.ndarray, dt_s: float):
        """IMU increments corrected with the estimated errors (``remove_imu_errors``)."""
        return remove_imu_errors(dtheta_b_rad, dvel_b_mps, dt_s, self.gyro_error_b_radps(),
                                 self.accel_bias_b_mps2, self.extra)


def remove_imu_errors(dtheta_b_rad, dvel_b_mps, dt_s: float, gyro_error_b_radps, accel_bias_b_mps2, extra: dict):
    """Bias (plus Markov drift) removed, then the scale factors of ``extra``
    ("sg", "sa") divided out: omega = (omega_meas - b) / (1 + s), exact for
    the model of core.state_layout. Shared by the ENU and LCI states."""
    dth = dtheta_b_rad - gyro_error_b_radps * dt_s
    dv = dvel_b_mps - accel_bias_b_mps2 * dt_s
    sg, sa = extra.get("sg"), extra.get("sa")
    if sg is not None:
        dth = dth / (1.0 + sg)
    if sa is not None:
        dv = dv / (1.0 + sa)
    return dth, dv
