"""The node's logic without ROS (same core live and offline): buffer the
IMU increments, GNSS measurements and fused states, form the position
residual fused - GNSS at each fix epoch (ENU m), feed the trigger once the
buffer holds a full window, and cut the window when it fires (section III.A,
Fig. 5)."""
from __future__ import annotations

from collections import Counter

import numpy as np

from hyper_nav_filter.core import earth

from .config import LeverArmLearningConfig
from .trigger import ResidualTrigger
from .window import DataWindow, WindowBuffer


class ReestimationMonitor:
    def __init__(self, cfg: LeverArmLearningConfig, monitor_from_s: float = -np.inf):
        """``monitor_from_s``: the trigger sees residuals from this epoch on."""
        self.cfg = cfg
        self.monitor_from_s = monitor_from_s
        self.buffer = WindowBuffer(cfg.window_s + 2.0 * cfg.state_period_s + 5.0)
        self.trigger = ResidualTrigger(cfg.trigger)
        self.counters: Counter = Counter()
        self._fixes: dict[int, object] = {}
        self._next_state_t = -np.inf

    def add_imu(self, t_s: float, dtheta_b_rad, dvel_b_mps) -> None:
        self.buffer.add_imu(t_s, dtheta_b_rad, dvel_b_mps)

    def add_gnss(self, meas) -> None:
        self.buffer.add_gnss(meas)
        if meas.kind == "gnss_pos":
            self._fixes[int(round(meas.t_s * 1e3))] = meas

    def add_state(self, state, P, busy: bool = False) -> DataWindow | None:
        """A fused state (without optional-block nominals) and its covariance;
        returns the window to re-estimate when the trigger fires, else None."""
        if state.t_s >= self._next_state_t - 1e-9:
            self.buffer.add_state(state, P)
            self._next_state_t = state.t_s + self.cfg.state_period_s
        fix = self._fixes.pop(int(round(state.t_s * 1e3)), None)
        for k in [k for k in self._fixes if k < (state.t_s - 10.0) * 1e3]:
            del self._fixes[k]
        if fix is None or state.t_s < self.monitor_from_s:
            return None
        if not self.buffer.covers(self.cfg.window_s, state.t_s):
            self.counters["not_ready"] += 1         # the trigger starts once a window can be cut
            return None
        res = earth.position_error_enu_m(state.lat_rad, state.lon_rad, state.alt_m, fix.lat_rad, fix.lon_rad,
                                         fix.alt_m)
        if not self.trigger.update(state.t_s, res):
            return None
        self.counters["trigger_fired"] += 1
        if busy:
            self.counters["suppressed_busy"] += 1
            return None
        window = self.buffer.window(self.cfg.window_s, state.t_s)
        if window is None:
            self.counters["suppressed_no_window"] += 1
        return window
