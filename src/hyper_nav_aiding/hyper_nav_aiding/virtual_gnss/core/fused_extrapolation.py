"""Vehicle antenna position at a GNSS epoch from the fused solution (the
"fused state" source of the virtual pseudoranges, issue #8).

The fused solution (``nav/state``) is released ``output_delay_s`` behind the
newest IMU sample. For a GNSS epoch t the extrapolator takes the newest
solution stamped at or before t - ``state_delay_s`` (the filter's output
delay plus a margin: that solution has been published by the time the IMU
sample of t arrives, whatever the arrival order of the topics, so the live
node and an offline run pick the same one) and carries it to t with the
IMU samples since, through the filter's own strapdown mechanization (:func:`hyper_nav_filter.core.mechanization.propagate`),
with its estimated biases. This is what the INS would say at t:
the virtual pseudoranges built on it carry no information the filter does
not already have (see the reproduction's discussion).
"""
from __future__ import annotations

from collections import deque

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_filter.core.mechanization import propagate
from hyper_nav_filter.core.nav_state import ImuSample, NavState


class StaleInput(ValueError):
    """The source cannot give a position at the epoch (no state, or too old)."""


class FusedStateExtrapolator:
    """Latest fused state + buffered IMU -> antenna ECEF position/velocity
    and the position 1-sigma at an epoch."""

    def __init__(self, lever_arm_b_m=(0.0, 0.0, 0.0), max_state_age_s: float = 5.0, state_delay_s: float = 1.1,
                 buffer_s: float = 10.0):
        self.lever_arm_b_m = np.asarray(lever_arm_b_m, float)
        self.max_state_age_s = float(max_state_age_s)
        self.state_delay_s = float(state_delay_s)
        self.buffer_s = float(buffer_s)
        self._imu: deque[ImuSample] = deque()
        self._states: deque[tuple[NavState, float]] = deque()

    def add_state(self, state: NavState, pos_sigma_m: float = 0.0) -> None:
        """A fused solution with its per-axis position 1-sigma [m] (ignored if
        not newer than the last one)."""
        if self._states and state.t_s <= self._states[-1][0].t_s:
            return
        self._states.append((state, float(pos_sigma_m)))
        while len(self._states) > 1 and self._states[1][0].t_s < state.t_s - self.buffer_s:
            self._states.popleft()

    def add_imu(self, sample: ImuSample) -> None:
        """An IMU sample (ascending time; older than the buffer are dropped)."""
        if self._imu and sample.t_s <= self._imu[-1].t_s:
            return
        self._imu.append(sample)
        while self._imu and self._imu[0].t_s < sample.t_s - self.buffer_s:
            self._imu.popleft()

    @property
    def state_t_s(self) -> float | None:
        """Stamp of the newest state."""
        return self._states[-1][0].t_s if self._states else None

    @property
    def imu_t_s(self) -> float | None:
        """Stamp of the newest IMU sample."""
        return self._imu[-1].t_s if self._imu else None

    def at(self, t_s: float):
        """(r_ant_e_m, v_ant_e_mps, pos_sigma_m) at t_s from the newest state
        stamped <= t_s - state_delay_s. Raises StaleInput without such a
        state, or if it is older than ``max_state_age_s`` and the IMU buffer
        does not reach back to it."""
        cand = [x for x in self._states if x[0].t_s <= t_s - self.state_delay_s + 1e-9]
        if not cand:
            raise StaleInput(f"no fused state (nav/state) stamped before {t_s - self.state_delay_s:.3f} s yet")
        s, pos_sigma = cand[-1]
        age = t_s - s.t_s
        if age < -1e-9:
            raise StaleInput(f"fused state at {s.t_s:.3f} s is newer than the epoch {t_s:.3f} s")
        steps = [m for m in self._imu if s.t_s + 1e-9 < m.t_s <= t_s + 1e-9]
        covered = steps and abs(steps[0].t_s - steps[0].dt_s - s.t_s) < 1e-6 and abs(steps[-1].t_s - t_s) < 1e-6
        if age > 1e-9 and not covered:
            if age > self.max_state_age_s:
                raise StaleInput(f"fused state {age:.2f} s old at {t_s:.3f} s (limit {self.max_state_age_s} s) "
                                 f"and no IMU samples to carry it")
            steps = []                                  # short gap: carry with the velocity only
        x = s.copy()
        # the interval ending at the state's epoch: the coning/sculling terms of the first step
        prev = next((m for m in reversed(self._imu) if abs(m.t_s - s.t_s) < 1e-6), None) if steps else None
        for m in steps:
            x = propagate(x, m, prev)
            prev = m
        if not steps and age > 1e-9:
            v = x.vel_enu_mps
            r_m, r_n = earth.radii(x.lat_rad)
            x.lat_rad += v[1] * age / (r_m + x.alt_m)
            x.lon_rad += v[0] * age / ((r_n + x.alt_m) * np.cos(x.lat_rad))
            x.alt_m += v[2] * age
        C_n_e = earth.C_n_e(x.lat_rad, x.lon_rad)
        r = earth.geodetic_to_ecef(x.lat_rad, x.lon_rad, x.alt_m) + C_n_e @ (x.C_b_n @ self.lever_arm_b_m)
        v = C_n_e @ x.vel_enu_mps
        return r, v, pos_sigma
