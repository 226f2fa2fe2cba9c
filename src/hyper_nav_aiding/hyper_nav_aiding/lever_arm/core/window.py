"""The data of one re-estimation window and the ring buffer it is cut from
(seed 000 section III.A: "the method collects the IMU and GNSS data closest to
the current time").

A window is what a filter pass needs to start at t0 and run to its end: the
fused solution at t0 (nominal state and covariance, as ``nav/state`` carries
them), the IMU increments after t0 and the GNSS fixes in (t0, t_end].
"""
from __future__ import annotations

import bisect
from collections import deque
from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core.nav_state import ImuSample, NavState


@dataclass(frozen=True)
class DataWindow:
    """IMU increments over (t_s[k] - dt, t_s[k]] (body FLU), GNSS measurements
    (``hyper_nav_filter.core.measurements`` objects, time-ordered) and the
    filter's state at ``initial_state.t_s`` with its covariance ``initial_P``
    (error-state layout of the filter configuration the window is replayed with)."""
    initial_state: NavState
    initial_P: np.ndarray
    imu_t_s: np.ndarray
    imu_dtheta_b_rad: np.ndarray
    imu_dvel_b_mps: np.ndarray
    gnss: tuple
    # the structure's load per IMU interval (``ImuSample.load_f_b_mps2``, (N, 3) m/s^2), or None
    imu_load_f_b_mps2: np.ndarray | None = None

    def imu_sample(self, k: int, t_prev_s: float):
        """The filter's ``ImuSample`` of interval k (previous stamp ``t_prev_s``)."""
        t = float(self.imu_t_s[k])
        return ImuSample(t, t - t_prev_s, self.imu_dtheta_b_rad[k], self.imu_dvel_b_mps[k],
                         None if self.imu_load_f_b_mps2 is None else self.imu_load_f_b_mps2[k])

    @property
    def t0_s(self) -> float:
        return self.initial_state.t_s

    @property
    def t_end_s(self) -> float:
        return float(self.imu_t_s[-1])

    @property
    def duration_s(self) -> float:
        return self.t_end_s - self.t0_s

    def check(self) -> None:
        """Raise ValueError on a window a filter pass cannot run."""
        n = len(self.imu_t_s)
        if n < 2:
            raise ValueError(f"window has {n} IMU samples")
        if self.imu_dtheta_b_rad.shape != (n, 3) or self.imu_dvel_b_mps.shape != (n, 3):
            raise ValueError("window IMU arrays must be (N, 3)")
        if not (self.imu_t_s[0] > self.t0_s and np.all(np.diff(self.imu_t_s) > 0)):
            raise ValueError("window IMU stamps must increase from after the initial state")
        if not all(np.all(np.isfinite(a)) for a in (self.imu_t_s, self.imu_dtheta_b_rad, self.imu_dvel_b_mps,
                                                     self.initial_P)):
            raise ValueError("window holds non-finite IMU data or covariance")
        if not self.gnss:
            raise ValueError("window holds no GNSS measurement")


class WindowBuffer:
    """Ring buffer of the most recent ``capacity_s`` of IMU samples, GNSS
    measurements and fused states (with covariance); ``window(duration_s)``
    cuts the latest window starting at a stored fused state."""

    def __init__(self, capacity_s: float):
        if capacity_s <= 0:
            raise ValueError("capacity_s must be > 0")
        self.capacity_s = float(capacity_s)
        self._imu: deque = deque()          # (t, dtheta, dvel, structural load or None)
        self._gnss: deque = deque()         # measurement objects (t_s)
        self._states: deque = deque()       # (t, NavState, P)
        self._t_ref = None                  # trim reference (advance); None: the newest IMU sample

    def add_imu(self, t_s: float, dtheta_b_rad, dvel_b_mps, load_f_b_mps2=None) -> bool:
        """Append an IMU sample (``load_f_b_mps2``: the structure's load over
        it, ``ImuSample``, when a source gives it); False (ignored) when not
        after the last one."""
        if self._imu and t_s <= self._imu[-1][0]:
            return False
        self._imu.append((float(t_s), np.asarray(dtheta_b_rad, float), np.asarray(dvel_b_mps, float),
                          None if load_f_b_mps2 is None else np.asarray(load_f_b_mps2, float)))
        self._trim()
        return True

    def add_gnss(self, meas) -> None:
        """Insert a GNSS measurement (late ones go to their place in time)."""
        if self._gnss and meas.t_s < self._gnss[-1].t_s:
            items = list(self._gnss)
            bisect.insort(items, meas, key=lambda m: m.t_s)
            self._gnss = deque(items)
        else:
            self._gnss.append(meas)
        self._trim()

    def add_state(self, state: NavState, P: np.ndarray) -> None:
        if self._states and state.t_s <= self._states[-1][0]:
            return
        self._states.append((state.t_s, state, np.asarray(P, float)))
        self._trim()

    @property
    def t_latest_s(self) -> float:
        return self._imu[-1][0] if self._imu else -np.inf

    def advance(self, t_s: float) -> None:
        """Trim relative to ``t_s`` (the consumer's own time, e.g. the newest
        fused state it took) instead of the newest IMU sample: what is kept
        then depends on the stamps only, not on how far the IMU stream runs
        ahead of the fused states (issue 22)."""
        self._t_ref = float(t_s)
        self._trim()

    def _trim(self) -> None:
        t_min = (self.t_latest_s if self._t_ref is None else self._t_ref) - self.capacity_s
        for q, key in ((self._imu, lambda x: x[0]), (self._gnss, lambda m: m.t_s), (self._states, lambda x: x[0])):
            while q and key(q[0]) < t_min:
                q.popleft()

    def covers(self, duration_s: float, t_end_s: float) -> bool:
        """True when a window of ``duration_s`` ending at ``t_end_s`` can be cut."""
        t_start = t_end_s - duration_s
        t0 = next((s[0] for s in reversed(self._states) if s[0] <= t_start + 1e-9), None)
        return t0 is not None and bool(self._imu) and self._imu[0][0] <= t0 + 0.5 * duration_s \
            and self._imu[-1][0] >= t_end_s - 1e-9

    def window(self, duration_s: float, t_end_s: float | None = None) -> DataWindow | None:
        """The window ending at ``t_end_s`` (default: the latest IMU sample)
        and starting at the latest stored fused state at or before
        t_end - duration_s; None when the buffer does not cover it."""
        t_end = self.t_latest_s if t_end_s is None else float(t_end_s)
        t_start = t_end - duration_s
        starts = [s for s in self._states if s[0] <= t_start + 1e-9]
        if not starts or not self._imu or self._imu[0][0] > starts[-1][0] + 0.5 * duration_s:
            return None
        t0, state, P = starts[-1]
        imu = [x for x in self._imu if t0 < x[0] <= t_end + 1e-9]
        gnss = tuple(m for m in self._gnss if t0 < m.t_s <= t_end + 1e-9)
        if len(imu) < 2 or not gnss or imu[0][0] - t0 > 2.0 * (imu[1][0] - imu[0][0]):
            return None
        load = np.array([x[3] for x in imu]) if all(x[3] is not None for x in imu) else None
        return DataWindow(state.copy(), P.copy(), np.array([x[0] for x in imu]),
                          np.array([x[1] for x in imu]), np.array([x[2] for x in imu]), gnss, load)
