"""The node's logic without ROS (same core live and offline): buffer the
IMU increments, GNSS measurements and fused states, form the position
residual fused - GNSS at each fix epoch (ENU m), feed the trigger once the
buffer holds a full window, and cut the window when it fires (section III.A,
Fig. 5).

Fused states are taken in stamp order once the inputs up to their stamp are
in: a GNSS fix stamped at or after the state has come (one receiver sends
its fixes in order), or the IMU is ``gnss_hold_s`` past it (no fix is
coming: an outage). So the residual at each fix epoch and the window cut do
not depend on the order the topics arrive in (issue 22); a fix later than
that is still buffered, in its place in time.
"""
from __future__ import annotations

from collections import Counter, deque

import numpy as np

from hyper_nav_gnss import earth

from hyper_nav_aiding.lever_arm.core.config import LeverArmLearningConfig
from hyper_nav_aiding.lever_arm.core.trigger import ResidualTrigger
from hyper_nav_aiding.lever_arm.core.window import DataWindow, WindowBuffer


class ReestimationMonitor:
    def __init__(self, cfg: LeverArmLearningConfig, monitor_from_s: float = -np.inf):
        """``monitor_from_s``: the trigger sees residuals from this epoch on."""
        self.cfg = cfg
        self.monitor_from_s = monitor_from_s
        self.buffer = WindowBuffer(cfg.window_s + 2.0 * cfg.state_period_s + 1.0)
        self.trigger = ResidualTrigger(cfg.trigger)
        self.counters: Counter = Counter()
        self._fixes: dict[int, object] = {}
        self._gnss_t = -np.inf                  # newest GNSS fix stamp
        self._held: deque = deque()             # (state, P) waiting for their inputs
        self._next_state_t = -np.inf

    def add_imu(self, t_s: float, dtheta_b_rad, dvel_b_mps, busy: bool = False,
                load_f_b_mps2=None) -> DataWindow | None:
        """An IMU increment (with the structure's load when a source gives it);
        the window to re-estimate if a held state became due."""
        self.buffer.add_imu(t_s, dtheta_b_rad, dvel_b_mps, load_f_b_mps2)
        return self._drain(busy)

    def add_gnss(self, meas, busy: bool = False) -> DataWindow | None:
        """A GNSS measurement; the window to re-estimate if a held state became due."""
        self.buffer.add_gnss(meas)
        if meas.kind == "gnss_pos":
            self._fixes[int(round(meas.t_s * 1e3))] = meas
            self._gnss_t = max(self._gnss_t, meas.t_s)
        return self._drain(busy)

    def add_state(self, state, P, busy: bool = False) -> DataWindow | None:
        """A fused state (without optional-block nominals) and its covariance;
        returns the window to re-estimate when the trigger fires, else None
        (states are taken in order once their inputs are in: module docstring)."""
        if self._held and state.t_s <= self._held[-1][0].t_s:
            self.counters["states_out_of_order"] += 1
            return None
        self._held.append((state, np.asarray(P, float)))
        return self._drain(busy)

    @property
    def held(self) -> int:
        """States waiting for their inputs."""
        return len(self._held)

    def _drain(self, busy: bool) -> DataWindow | None:
        """Take the held states whose inputs are in, in order; stop at a window."""
        while self._held:
            t = self._held[0][0].t_s
            if self._gnss_t < t - 1e-9 and self.buffer.t_latest_s < t + self.cfg.gnss_hold_s - 1e-9:
                return None
            state, P = self._held.popleft()
            window = self._take_state(state, P, busy)
            if window is not None:
                return window
        return None

    def _take_state(self, state, P, busy: bool) -> DataWindow | None:
        self.buffer.advance(state.t_s)            # keep what the windows ending here need, by stamps
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
