"""Land-vehicle constraints: zero-velocity updates at standstill and the
non-holonomic constraint (Groves, Principles of GNSS, Inertial, and
Multisensor Integrated Navigation Systems, 2nd ed., sections 15.3.2-15.3.3;
the GNSS_IMU project of rtklibexplorer uses both). Off by default: they are
declared sources (``sources/land.py``: ``zupt``, ``nhc``), never implied.

* ``ZeroVelocity``: at standstill the velocity is zero,
  residual = v_ENU, H_vel = I (Groves eq. 15.10).
* ``NonHolonomic``: a wheeled vehicle neither slides sideways nor leaves
  the road, v_b = C_n_b v_n has zero lateral (y) and vertical (z) parts in
  body FLU (the IMU's body axes are the vehicle's: the import's mounting
  puts them there). With this filter's attitude error convention
  C_b_n_est = (I - [phi x]) C_b_n (``measurements``: H_att = skew(C l) for
  a lever arm), v_b_est = v_b + C_n_b dv - C_n_b [v x] phi, so
  H_vel = C_n_b[1:3], H_att = -C_n_b[1:3] [v x] (Groves eq. 15.11-15.14,
  in our notation).
* ``StandstillDetector``: the IMU says the vehicle stands still when, over
  the last ``window_s``, every body rate stays below ``gyro_max_deg_per_s``
  and the specific force's magnitude varies by less than
  ``accel_std_max_mps2`` (one standard deviation) -- the "moving variance
  + angular rate" test of the ZUPT literature (Groves 15.3.2). A car at
  constant speed on a smooth road may pass it too: the thresholds are the
  user's, and the ZUPT's sigma says how much it is trusted.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import math

import numpy as np

from .attitude import skew
from .measurements import Measurement
from .nav_state import NavState
from .state_layout import StateLayout


@dataclass(frozen=True)
class ZeroVelocity(Measurement):
    """Zero velocity at epoch t_s (standstill), ENU covariance (m/s)^2."""
    t_s: float
    var_mps2: float
    kind: str = "zupt"
    coupling = "aiding"

    def model(self, state: NavState, layout: StateLayout, ctx):
        H = np.zeros((3, layout.dim))
        H[:, layout.sl("vel")] = np.eye(3)
        return np.array(state.vel_enu_mps, float), H, np.eye(3) * self.var_mps2


@dataclass(frozen=True)
class NonHolonomic(Measurement):
    """Zero lateral and vertical body velocity at epoch t_s, variance (m/s)^2 each."""
    t_s: float
    var_mps2: float
    kind: str = "nhc"
    coupling = "aiding"

    def model(self, state: NavState, layout: StateLayout, ctx):
        C_n_b = np.asarray(state.C_b_n, float).T
        v = np.asarray(state.vel_enu_mps, float)
        rows = C_n_b[1:3]
        H = np.zeros((2, layout.dim))
        H[:, layout.sl("vel")] = rows
        H[:, layout.sl("att")] = -rows @ skew(v)
        return rows @ v, H, np.eye(2) * self.var_mps2


class StandstillDetector:
    """The moving-window standstill test of the module docstring, fed one
    IMU sample (mean rates over its interval) at a time."""

    def __init__(self, window_s: float, gyro_max_deg_per_s: float, accel_std_max_mps2: float):
        self.window_s = float(window_s)
        self.gyro_max_radps = math.radians(gyro_max_deg_per_s)
        self.accel_std_max = float(accel_std_max_mps2)
        self._buf: deque = deque()          # (t, max |omega| component, |f|)

    def add(self, t_s: float, omega_b_radps, f_b_mps2) -> bool:
        """Add a sample; True when the window ending at it is a standstill."""
        w = float(np.max(np.abs(omega_b_radps)))
        f = float(np.linalg.norm(f_b_mps2))
        buf = self._buf
        buf.append((t_s, w, f))
        while buf and buf[0][0] < t_s - self.window_s - 1e-9:
            buf.popleft()
        if len(buf) < 3 or buf[-1][0] - buf[0][0] < 0.9 * self.window_s:
            return False
        if max(x[1] for x in buf) > self.gyro_max_radps:
            return False
        fs = np.fromiter((x[2] for x in buf), float, len(buf))
        return float(np.std(fs)) < self.accel_std_max
