"""Fusion engine: the ESKF fed by time-stamped IMU and aiding measurements.

Measurements are processed in timestamp order whatever order they arrive in.
The engine keeps, for a window of ``reprocess_window_s``, every IMU sample and
the filter snapshot after each IMU epoch. A measurement stamped before the
latest IMU epoch (late, e.g. a GNSS fix delivered 200 ms after its epoch)
restores the snapshot before its epoch and re-runs the stored IMU samples and
measurements from there, so the result is the same as if it had arrived on
time. Solutions are released ``output_delay_s`` behind the latest IMU epoch,
which makes them independent of arrival order for delays up to that value
(the live node and an offline run over a bag give identical numbers).
"""
from __future__ import annotations

import bisect
from collections import Counter
from dataclasses import dataclass

import numpy as np

from . import earth
from .config import FilterConfig
from .eskf import ErrorStateKF, FilterSnapshot
from .measurements import ModelContext, is_finite
from .nav_state import ImuSample, NavState

MODE_INITIALIZING, MODE_INS_ONLY, MODE_LOOSELY_COUPLED = 1, 2, 3


def make_filter(cfg: FilterConfig, initial: NavState):
    """The error-state filter of the configured mechanization frame
    (``cfg.mechanization_frame``: "ENU" or "LCI")."""
    if cfg.mechanization_frame == "LCI":
        from .lci.filter import LciErrorStateKF
        return LciErrorStateKF(cfg, initial, cfg.initial_covariance())
    return ErrorStateKF(cfg, initial, cfg.initial_covariance())


@dataclass
class Solution:
    t_s: float
    state: NavState
    P: np.ndarray
    mode: int
    n_updates: int
    n_rejected: int
    last_nis: float
    omega_ib_b_radps: np.ndarray
    f_b_mps2: np.ndarray


@dataclass
class _Epoch:
    imu: ImuSample
    snap: FilterSnapshot
    last_update_t_s: float
    Phi: np.ndarray | None = None        # transition from the previous epoch
    P_prior: np.ndarray | None = None    # covariance before this epoch's updates
    dx: np.ndarray | None = None         # sum of the error corrections applied here


class FusionEngine:
    def __init__(self, cfg: FilterConfig, initial: NavState, keep_history: bool = False):
        """``keep_history`` stores every epoch for the offline RTS smoother."""
        self.cfg = cfg
        self.keep_history = keep_history
        self.history: list[_Epoch] = []
        self.kf = make_filter(cfg, initial.copy())
        self._base = self.kf.snapshot()          # state before the first stored epoch
        self._base_last_update = -np.inf
        self._epochs: list[_Epoch] = []
        self._times: list[float] = []
        self._meas: list[tuple[float, str, int, object]] = []   # sorted (t, kind, seq, meas)
        self._seq = 0
        self._next_output_t = initial.t_s
        self._last_released_t = -np.inf
        self._dirty_from = 10**9
        self.counters: Counter = Counter()
        self.nis_by_kind: dict[str, list[float]] = {}

    @property
    def t_latest_s(self) -> float:
        return self._times[-1] if self._times else self._base.state.t_s

    # ---- inputs -----------------------------------------------------------------
    def add_imu(self, t_s: float, dtheta_b_rad, dvel_b_mps) -> tuple[bool, str]:
        """Add an IMU sample stamped at the end of its interval. Returns
        (accepted, reason); rejected samples are counted, never raised."""
        dtheta_b_rad = np.asarray(dtheta_b_rad, dtype=float)
        dvel_b_mps = np.asarray(dvel_b_mps, dtype=float)
        if not (np.isfinite(t_s) and np.all(np.isfinite(dtheta_b_rad)) and np.all(np.isfinite(dvel_b_mps))):
            return self._reject("imu_nan")
        dt = t_s - self.t_latest_s
        if dt <= 0.0:
            return self._reject("imu_out_of_order")
        if dt > self.cfg.reprocess_window_s:
            return self._reject("imu_gap")
        imu = ImuSample(t_s, dt, dtheta_b_rad, dvel_b_mps)
        self._catch_up()
        self._process_epoch(len(self._epochs), imu)
        self.counters["imu_accepted"] += 1
        self._trim()
        return True, "ok"

    def add_imu_rates(self, t_s: float, omega_b_radps, f_b_mps2) -> tuple[bool, str]:
        """Add an IMU sample given as mean rates over (t_latest, t_s] (the
        sensor_msgs/Imu mapping); increments = rate * (t_s - t_latest)."""
        dt = t_s - self.t_latest_s
        return self.add_imu(t_s, np.asarray(omega_b_radps, float) * dt, np.asarray(f_b_mps2, float) * dt)

    def add_measurement(self, meas) -> tuple[bool, str]:
        """Queue an aiding measurement (``meas.t_s`` is its epoch). Late ones
        trigger re-processing from their epoch."""
        kind = meas.kind
        if not is_finite(meas):
            return self._reject(f"{kind}_nan")
        if meas.t_s <= self._base.state.t_s:
            return self._reject(f"{kind}_stale")
        if meas.t_s <= self._last_released_t + 1e-9:
            # still applied, but solutions already released did not see it:
            # a delay longer than output_delay_s (live and offline may differ)
            self.counters[f"{kind}_after_release"] += 1
        self._seq += 1
        bisect.insort(self._meas, (meas.t_s, kind, self._seq, meas))
        self.counters[f"{kind}_received"] += 1
        if self._times and meas.t_s <= self._times[-1] + 1e-9:
            # re-process lazily: several measurements of one epoch cost one pass
            j = bisect.bisect_left(self._times, meas.t_s - 1e-9)
            if meas.t_s < self._times[-1] - 1e-9:
                self.counters[f"{kind}_late"] += 1
            self._dirty_from = min(self._dirty_from, j)
        return True, "ok"

    def _catch_up(self) -> None:
        """Re-process the stored epochs from the earliest one a late
        measurement touched."""
        if self._dirty_from < len(self._epochs):
            self.counters["epochs_reprocessed"] += len(self._epochs) - self._dirty_from
            for k in range(self._dirty_from, len(self._epochs)):
                self._process_epoch(k, self._epochs[k].imu)
        self._dirty_from = len(self._epochs) + 10**9

    def release(self, final: bool = False) -> list[Solution]:
        """Solutions now older than output_delay_s (all of them when final)."""
        self._catch_up()
        out = []
        horizon = self.t_latest_s - (0.0 if final else self.cfg.output_delay_s)
        for ep in self._epochs:
            t = ep.imu.t_s
            if t < self._next_output_t - 1e-9:
                continue
            if t > horizon + 1e-9:
                break
            out.append(self._solution(ep))
            self._last_released_t = t
            while self._next_output_t <= t + 1e-9:
                self._next_output_t += 1.0 / self.cfg.output_rate_hz
        return out

    def full_history(self) -> list:
        """Every processed epoch so far (needs keep_history=True)."""
        self._catch_up()
        if not self.keep_history:
            raise RuntimeError("FusionEngine(keep_history=True) is needed for the smoother")
        return self.history + self._epochs

    # ---- internals --------------------------------------------------------------
    def _reject(self, reason: str):
        self.counters[f"rejected_{reason}"] += 1
        return False, reason

    def _process_epoch(self, k: int, imu: ImuSample) -> None:
        prev = self._epochs[k - 1] if k > 0 else None
        self.kf.restore(prev.snap if prev else self._base)
        last_update = prev.last_update_t_s if prev else self._base_last_update
        t_prev = self.kf.state.t_s
        self.kf.predict(imu)
        lo = bisect.bisect_right(self._meas, (t_prev + 1e-9,))
        hi = bisect.bisect_right(self._meas, (imu.t_s + 1e-9,))
        omega_nb_b = self._omega_nb_b(imu)
        for t_m, kind, _, meas in self._meas[lo:hi]:
            ctx = ModelContext(np.asarray(self.cfg.antenna_lever_arm_b_m, float), omega_nb_b, t_m - imu.t_s)
            res = self.kf.update(kind, t_m, *self.kf.model(meas, ctx))
            if res.accepted:
                last_update = t_m
        ep = _Epoch(imu, self.kf.snapshot(), last_update)
        if self.keep_history:
            ep.Phi, ep.P_prior, ep.dx = self.kf.last_Phi, self.kf.P_prior, self.kf.epoch_dx
        if k == len(self._epochs):
            self._epochs.append(ep)
            self._times.append(imu.t_s)
        else:
            self._epochs[k] = ep

    def _omega_nb_b(self, imu: ImuSample) -> np.ndarray:
        s = self.kf.state
        w_in = earth.omega_ie_n(s.lat_rad) + earth.omega_en_n(s.lat_rad, s.alt_m, s.vel_enu_mps)
        return imu.dtheta_b_rad / imu.dt_s - s.gyro_error_b_radps() - s.C_b_n.T @ w_in

    def _trim(self) -> None:
        t_min = self.t_latest_s - self.cfg.reprocess_window_s
        n_drop = 0
        while n_drop < len(self._epochs) - 1 and self._times[n_drop] < t_min \
                and self._times[n_drop] < self._next_output_t - 1e-9:
            n_drop += 1
        if n_drop:
            if self.keep_history:
                self.history.extend(self._epochs[:n_drop])
            self._base = self._epochs[n_drop - 1].snap
            self._base_last_update = self._epochs[n_drop - 1].last_update_t_s
            del self._epochs[:n_drop]
            del self._times[:n_drop]
            cut = bisect.bisect_right(self._meas, (self._base.state.t_s + 1e-9,))
            del self._meas[:cut]

    def _solution(self, ep: _Epoch) -> Solution:
        snap = ep.snap
        t = ep.imu.t_s
        if snap.n_updates == 0:
            mode = MODE_INITIALIZING
        elif t - ep.last_update_t_s > 1.0:
            mode = MODE_INS_ONLY
        else:
            mode = MODE_LOOSELY_COUPLED
        s = snap.state
        return Solution(t, s.copy(), snap.P.copy(), mode, snap.n_updates, snap.n_rejected, snap.last_nis,
                        ep.imu.dtheta_b_rad / ep.imu.dt_s - s.gyro_error_b_radps(),
                        ep.imu.dvel_b_mps / ep.imu.dt_s - s.accel_bias_b_mps2)
