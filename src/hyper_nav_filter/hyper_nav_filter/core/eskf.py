"""Error-state Kalman filter on a strapdown INS, in any mechanization frame.

The filter composes a frame (``core.frames``: nominal state, mechanization,
att/vel/pos error dynamics) with the configured state blocks
(``core.blocks``, assembled by ``core.system_model``). It owns the nominal
state (the frame's vector and the blocks' values), the error covariance in
the frame's own error convention, and the predict/update cycle:

* ``predict`` corrects one IMU interval with the blocks' current error
  estimates (biases, scale factors, the lever-arm pre-processing), runs the
  frame's mechanization, propagates the blocks' nominal values and P;
* ``update`` takes any measurement's (residual, H, R), gates it with a
  chi-square test on the normalized innovation squared, applies the
  Joseph-form update and injects the error estimate into the nominal state.
  ``model`` evaluates a measurement model (written once, in the ENU error
  convention, on the geodetic/ENU view of the state) and maps its Jacobian
  into the frame's own error state.

State arrays are never modified in place (every step makes new ones), so a
snapshot is a set of references and costs nothing to take.
"""
from __future__ import annotations

from dataclasses import dataclass
import math
from typing import NamedTuple

import numpy as np

from . import lockout
from .blocks.base import Block
from .blocks.nav import Attitude
from .config import FilterConfig
from .fast import predict as fast_predict
from .fast import update as fast_update
from .frames import make_frame
from .nav_state import ImuSample, NavState
from .system_model import discretize, system_model

_F64 = np.dtype(np.float64)


@dataclass
class UpdateResult:
    kind: str
    t_s: float
    nis: float
    accepted: bool
    residual: np.ndarray


@dataclass(frozen=True)
class Linearization:
    imu: ImuSample                 # the interval after IMU pre-processing (kept as imu_prev)
    dth: np.ndarray                # corrected increments of this interval
    dv: np.ndarray
    dth_p: np.ndarray | None       # ... and of the previous one (None at the first step)
    dv_p: np.ndarray | None
    values: np.ndarray             # block values after pre-processing
    F: np.ndarray
    G: np.ndarray
    qc: np.ndarray
    Phi: np.ndarray
    Q: np.ndarray


class FilterSnapshot(NamedTuple):
    """Everything needed to resume the filter at an epoch (re-processing,
    smoothing), including the configuration (model) in force. (A NamedTuple
    of references: one is taken per IMU epoch.)"""
    t_s: float
    x_nav: np.ndarray
    values: np.ndarray
    P: np.ndarray                  # the frame's own error convention
    imu_prev: ImuSample | None
    cfg: FilterConfig
    n_updates: int
    n_rejected: int
    last_nis: float
    stats: dict                    # {kind: (accepted, gated, sum of NIS/dof)}, never mutated
    watch: dict = {}               # {kind: lockout.Watch}: the gate's lock-out monitor, never mutated


class ErrorStateKF:
    def __init__(self, config: FilterConfig, state: NavState, P0: np.ndarray | None = None, fast: bool = True,
                 **frame_kw):
        """``state``: initial nominal state (geodetic/ENU view, block values in
        its bias fields and ``extra``); ``P0`` in the ENU error convention
        (default ``config.initial_covariance()``). ``fast``: the compiled
        predict (core.fast) where the frame has one; False keeps the numpy
        reference implementation (``linearize``), which tests compare with."""
        self.cfg = config
        self.layout = config.layout
        self.frame = make_frame(config, state, **frame_kw)
        self.fast = fast
        self._set_model(config)
        self.t_s = float(state.t_s)
        self.x_nav = self.frame.nominal(state)
        self.values = self._values_from(state)
        P0 = config.initial_covariance() if P0 is None else np.asarray(P0, float)
        T = self.to_enu()
        if T is None:
            self.P = P0.copy()
        else:
            Ti = np.linalg.inv(T)
            self.P = 0.5 * (Ti @ P0 @ Ti.T + (Ti @ P0 @ Ti.T).T)
        self.imu_prev: ImuSample | None = None
        self.n_updates = 0
        self.n_rejected = 0
        self.last_nis = float("nan")
        self.stats: dict[str, tuple] = {}
        self.watch: dict[str, lockout.Watch] = {}
        # per-epoch quantities the RTS smoother needs (see smoother.py)
        self.last_Phi = np.eye(self.layout.dim)
        self.P_prior = self.P
        self.epoch_dx = np.zeros(self.layout.dim)
        self._gate: dict[int, float] = {}

    @property
    def fast(self) -> bool:
        return self._fast

    @fast.setter
    def fast(self, value: bool) -> None:
        """The frame follows (its geodetic view has a compiled form too)."""
        self._fast = bool(value)
        self.frame.fast = self._fast

    def _set_model(self, cfg: FilterConfig) -> None:
        self.cfg = cfg
        self.sys = system_model(cfg)
        self.lockout_rule = lockout.LockoutRule.of(cfg)
        lay = cfg.layout
        self._roles = {role: [lay.value_sl(b.name) for b in lay.value_blocks if b.imu_role == role]
                       for role in ("gyro_bias", "accel_bias", "gyro_scale", "accel_scale")}
        self._preprocessors = [(b, lay.value_sl(b.name)) for b in lay.value_blocks if b.preprocess is not None]
        self._propagated = [(b, lay.value_sl(b.name)) for b in lay.value_blocks
                            if type(b).propagate is not Block.propagate]
        self._value_fields = [(b.name, b.nav_state_field, lay.value_sl(b.name)) for b in lay.value_blocks]

    # ---- views ------------------------------------------------------------------------
    def _values_from(self, nav: NavState) -> np.ndarray:
        parts = []
        for b in self.layout.value_blocks:
            v = getattr(nav, b.nav_state_field) if b.nav_state_field else nav.extra.get(b.name)
            parts.append(b.initial_value(self.cfg) if v is None else np.asarray(v, float))
        return np.concatenate(parts) if parts else np.zeros(0)

    def view(self, t_s: float, x_nav: np.ndarray, values: np.ndarray) -> NavState:
        """The geodetic/ENU NavState of a nominal state (a fresh object)."""
        lat, lon, alt, v, C = self.frame.view(x_nav, t_s)
        fields, extra = {}, {}
        for name, field, s in self._value_fields:
            if field:
                fields[field] = values[s].copy()
            else:
                extra[name] = values[s].copy()
        return NavState(t_s, lat, lon, alt, v, C, extra=extra, **fields)

    @property
    def state(self) -> NavState:
        """The current nominal state as a geodetic/ENU NavState (a copy)."""
        return self.view(self.t_s, self.x_nav, self.values)

    def to_enu(self, x_nav=None, t_s=None) -> np.ndarray | None:
        """n x n transform of this filter's error state into the ENU convention
        (None when the frame is ENU, i.e. the identity)."""
        T9 = self.frame.to_enu(self.x_nav if x_nav is None else x_nav, self.t_s if t_s is None else t_s)
        if T9 is None:
            return None
        T = np.eye(self.layout.dim)
        T[:9, :9] = T9
        return T

    def P_enu(self, snap: FilterSnapshot | None = None) -> np.ndarray:
        """The error covariance in the ENU convention (of a snapshot, or now)."""
        x, t, P = (self.x_nav, self.t_s, self.P) if snap is None else (snap.x_nav, snap.t_s, snap.P)
        T9 = self.frame.to_enu(x, t)
        if T9 is None:
            return P
        T = np.eye(len(P))
        T[:9, :9] = T9
        out = T @ P @ T.T
        return 0.5 * (out + out.T)

    def snapshot_state(self, snap: FilterSnapshot) -> NavState:
        return self.view(snap.t_s, snap.x_nav, snap.values)

    # ---- bookkeeping for re-processing -----------------------------------------------
    def snapshot(self) -> FilterSnapshot:
        return FilterSnapshot(self.t_s, self.x_nav, self.values, self.P, self.imu_prev, self.cfg, self.n_updates,
                              self.n_rejected, self.last_nis, self.stats, self.watch)

    def restore(self, snap: FilterSnapshot) -> None:
        self.t_s, self.x_nav, self.values, self.P, self.imu_prev = snap.t_s, snap.x_nav, snap.values, snap.P, \
            snap.imu_prev
        if snap.cfg is not self.cfg:
            self._set_model(snap.cfg)
        self.n_updates, self.n_rejected, self.last_nis, self.stats, self.watch = snap.n_updates, \
            snap.n_rejected, snap.last_nis, snap.stats, snap.watch

    def apply_model_update(self, values: dict) -> None:
        """Adopt new values of updatable configuration fields from now on
        (a time-stamped model update; ``FilterConfig.with_updates``)."""
        self._set_model(self.cfg.with_updates(values))

    # ---- IMU error correction ---------------------------------------------------------
    def corrected(self, dtheta_b_rad, dvel_b_mps, dt_s: float, values=None):
        """Increments with the blocks' IMU errors removed: biases (bg + gm,
        ba), then the scale factors divided out, omega = (omega_meas - b) / (1 + s)."""
        v = self.values if values is None else values
        dth, dv = dtheta_b_rad, dvel_b_mps
        for s in self._roles["gyro_bias"]:
            dth = dth - v[s] * dt_s
        for s in self._roles["accel_bias"]:
            dv = dv - v[s] * dt_s
        for s in self._roles["gyro_scale"]:
            dth = dth / (1.0 + v[s])
        for s in self._roles["accel_scale"]:
            dv = dv / (1.0 + v[s])
        return dth, dv

    # ---- predict ----------------------------------------------------------------------
    def predict(self, imu: ImuSample) -> None:
        """Mechanize one IMU interval and propagate the covariance."""
        if self.fast:
            self._predict_fast(imu)
            return
        lin = self.linearize(imu)
        self.x_nav = self.frame.mechanize(self.x_nav, self.t_s, lin.dth, lin.dv, lin.dth_p, lin.dv_p, imu.dt_s,
                                          None if self.imu_prev is None else self.imu_prev.dt_s)
        new_vals = lin.values
        for blk, s in self._propagated:
            new_vals = new_vals.copy() if new_vals is self.values else new_vals
            new_vals[s] = blk.propagate(new_vals[s], imu.dt_s, self.cfg)
        self.values = new_vals
        self.imu_prev = lin.imu
        self.t_s = imu.t_s
        P = lin.Phi @ self.P @ lin.Phi.T + lin.Q
        self.P = 0.5 * (P + P.T)
        self._add_rate_error_q(imu)
        self.last_Phi, self.P_prior = lin.Phi, self.P
        self.epoch_dx = None

    def _predict_fast(self, imu: ImuSample) -> None:
        """``predict`` through the frame's compiled kernel (same equations as
        ``linearize`` + the mechanization); IMU pre-processing blocks and
        nominal block propagation around it as in the reference. The kernels
        take float64 arrays (any layout); anything else is converted here."""
        a, b = imu.dtheta_b_rad, imu.dvel_b_mps
        if type(a) is not np.ndarray or type(b) is not np.ndarray or a.dtype is not _F64 or b.dtype is not _F64:
            imu = imu._replace(dtheta_b_rad=np.asarray(a, dtype=np.float64), dvel_b_mps=np.asarray(b, dtype=np.float64))
        vals = new_vals = self.values
        if self._preprocessors:
            dt = imu.dt_s
            prev = self.imu_prev
            p = imu if prev is None else prev            # fixed argument types: one compiled signature
            gb, ab, sg, sa = self.sys.roles_args
            dth, dv, w_prev = fast_predict.corrected_pair(imu.dtheta_b_rad, imu.dvel_b_mps, float(dt),
                                                          p.dtheta_b_rad, float(p.dt_s), prev is not None, vals, gb, ab, sg, sa)
            if prev is None:
                w_prev = None
            new_vals = vals.copy()
            for blk, s in self._preprocessors:
                dv_remove, new_vals[s] = blk.preprocess(vals[s], dth, dv, w_prev, dt, self.cfg, True, imu.load_f_b_mps2)
                imu = imu._replace(dvel_b_mps=imu.dvel_b_mps - dv_remove)
        self.x_nav, self.P, Phi = self.frame.fast_predict(self.x_nav, self.t_s, vals, self.P, imu,
                                                          self.imu_prev, self.sys)
        self._add_rate_error_q(imu)
        for blk, s in self._propagated:
            new_vals = new_vals.copy() if new_vals is vals else new_vals
            new_vals[s] = blk.propagate(new_vals[s], imu.dt_s, self.cfg)
        self.values = new_vals
        self.imu_prev = imu
        self.t_s = imu.t_s
        self.last_Phi, self.P_prior = Phi, self.P
        self.epoch_dx = None

    def propagate_nominal(self, x_nav, t_s: float, values, imu_prev: ImuSample | None, imu: ImuSample):
        """The nominal half of ``predict``, on a given state and without P:
        the interval corrected with ``values`` (biases, scale factors, the
        lever-arm pre-processing of its blocks), the frame's mechanization and
        the blocks' nominal propagation. Returns (x_nav, values, imu as kept
        for the next interval's coning/sculling terms). Nothing of the filter
        changes (the output predictor, ``core.output_predictor``, runs it
        ahead of the fusion horizon); equal to ``predict``'s nominal state to
        rounding (tested)."""
        dt = imu.dt_s
        new_vals = values
        if self._preprocessors:
            dth, dv = self.corrected(imu.dtheta_b_rad, imu.dvel_b_mps, dt, values)
            w_prev = None if imu_prev is None else \
                self.corrected(imu_prev.dtheta_b_rad, imu_prev.dvel_b_mps, imu_prev.dt_s, values)[0] / imu_prev.dt_s
            new_vals = values.copy()
            for blk, s in self._preprocessors:
                dv_remove, new_vals[s] = blk.preprocess(values[s], dth, dv, w_prev, dt, self.cfg, self.fast,
                                                        imu.load_f_b_mps2)
                imu = imu._replace(dvel_b_mps=imu.dvel_b_mps - dv_remove)
        x1 = self.frame.mechanize_nominal(x_nav, t_s, values, imu, imu_prev, self.sys)
        for blk, s in self._propagated:
            new_vals = new_vals.copy() if new_vals is values else new_vals
            new_vals[s] = blk.propagate(new_vals[s], dt, self.cfg)
        return x1, new_vals, imu

    def lead_covariance(self, P, x_nav, t_s: float, values, imu: ImuSample, lead_s: float) -> np.ndarray:
        """P carried over ``lead_s`` seconds in one step, Phi P Phi^T + Q
        (``system_model.discretize``), with F at the state (x_nav, values) and
        the body rate and specific force of ``imu`` (the newest interval):
        the covariance of the output predictor's state, lead_s ahead of the
        filter's. P itself when lead_s is 0."""
        if lead_s <= 0.0:
            return P
        dth, dv = self.corrected(imu.dtheta_b_rad, imu.dvel_b_mps, imu.dt_s, values)
        w, f = dth / imu.dt_s, dv / imu.dt_s
        F9, C = self.frame.error_dynamics(x_nav, t_s, f, w)
        F, G, qc = self.sys.matrices(F9, C, w, f, np.zeros(3))
        Phi, Q = discretize(F, G, qc, lead_s, self.sys.exact)
        out = Phi @ P @ Phi.T + Q
        return 0.5 * (out + out.T)

    def _add_rate_error_q(self, imu: ImuSample) -> None:
        """The attitude block's rate-proportional gyro error (``blocks.nav``,
        gyro_rate_error_pct): isotropic, added to P's attitude diagonal after
        the predict (no-op when the parameter is 0)."""
        if self.cfg.gyro_rate_error_pct <= 0.0:
            return
        q = Attitude.rate_error_q(self.cfg, imu.dtheta_b_rad, imu.dt_s)
        k = self.cfg.layout.sl("att").start
        P = self.P
        P[k, k] += q
        P[k + 1, k + 1] += q
        P[k + 2, k + 2] += q

    def linearize(self, imu: ImuSample) -> "Linearization":
        """Everything one predict step needs, at the current state, without
        changing it: the corrected increments of this and the previous
        interval, the blocks' values after IMU pre-processing (the lever-arm
        modes), F, G, qc and the discrete Phi, Q."""
        dt = imu.dt_s
        vals = self.values
        dth, dv = self.corrected(imu.dtheta_b_rad, imu.dvel_b_mps, dt, vals)
        prev = self.imu_prev
        if prev is None:
            dth_p = dv_p = w_prev = None
            wdot = np.zeros(3)
        else:
            dth_p, dv_p = self.corrected(prev.dtheta_b_rad, prev.dvel_b_mps, prev.dt_s, vals)
            w_prev = dth_p / prev.dt_s
            wdot = (dth / dt - w_prev) / dt
        new_vals = vals
        for blk, s in self._preprocessors:
            dv_remove, v1 = blk.preprocess(vals[s], dth, dv, w_prev, dt, self.cfg, self.fast, imu.load_f_b_mps2)
            imu = imu._replace(dvel_b_mps=imu.dvel_b_mps - dv_remove)
            dth, dv = self.corrected(imu.dtheta_b_rad, imu.dvel_b_mps, dt, vals)
            new_vals = new_vals.copy() if new_vals is vals else new_vals
            new_vals[s] = v1
        w, f = dth / dt, dv / dt
        F9, C = self.frame.error_dynamics(self.x_nav, self.t_s, f, w)
        F, G, qc = self.sys.matrices(F9, C, w, f, wdot)
        Phi, Q = discretize(F, G, qc, dt, self.sys.exact)
        return Linearization(imu, dth, dv, dth_p, dv_p, new_vals, F, G, qc, Phi, Q)

    def error(self, est: FilterSnapshot, truth: FilterSnapshot) -> np.ndarray:
        """Error state (estimate - truth) between two states of this filter, in
        its own convention (the inverse of ``inject`` to first order)."""
        return np.concatenate([self.frame.difference(est.x_nav, truth.x_nav), est.values - truth.values])

    # ---- update -----------------------------------------------------------------------
    def apply_resets(self, resets) -> None:
        """Re-initialise elements of state blocks, each (block name, index in
        the block, sigma): its row and column of P zeroed, its variance
        sigma^2, its nominal value 0 -- a state that starts anew (a range-bias
        slot taken by a newly used satellite, ``blocks.range_bias``). P and
        the values are replaced, not changed in place (snapshots hold them)."""
        if not resets:
            return
        P, values = self.P.copy(), self.values.copy()
        for name, i, sigma in resets:
            k = self.layout.sl(name).start + int(i)
            P[k, :] = 0.0
            P[:, k] = 0.0
            P[k, k] = float(sigma) ** 2
            values[k - self.layout.nav_dim] = 0.0
        self.P, self.values = P, values

    def model(self, meas, ctx):
        """(residual, H, R) of a measurement at the current state, H in this
        filter's own error state (models are written in the ENU convention).
        The measurement's ``state_resets`` (see :meth:`apply_resets`) are
        applied first: part of the measurement event, so re-processing a late
        event repeats them (``measurements.Measurement`` declares what every
        measurement has)."""
        self.apply_resets(meas.state_resets)
        fast_model = meas.fast_model if self.fast else None
        if fast_model is not None:          # compiled form, on the geodetic/ENU view only
            residual, H, R = fast_model(self.frame.view(self.x_nav, self.t_s), self.layout, ctx)
        else:
            residual, H, R = meas.model(self.state, self.layout, ctx)
        T9 = self.frame.to_enu(self.x_nav, self.t_s)
        if T9 is not None:
            H = np.array(H, float)
            H[:, :9] = H[:, :9] @ T9
        return residual, H, R

    def gate_threshold(self, dof: int) -> float:
        if dof not in self._gate:
            from scipy.stats import chi2        # here: scipy.stats costs 0.5 s at a process's start (0.68 s CPU)
            self._gate[dof] = float(chi2.ppf(self.cfg.gate_probability, dof))
        return self._gate[dof]

    def update(self, kind: str, t_s: float, residual, H, R) -> UpdateResult:
        """Apply a measurement: residual = predicted - measured, H its Jacobian
        w.r.t. this filter's error state, R its covariance. A refusal by the
        gate feeds the lock-out monitor (``core.lockout``): a source refused
        for too long is taken back by a covariance inflation, counted in
        ``watch``."""
        residual = np.asarray(residual, dtype=float)
        dof = len(residual)
        acc, gated, nis_sum = self.stats.get(kind, (0, 0, 0.0))
        if lockout.is_far(residual, R):
            w = self.watch.get(kind, lockout.Watch())
            self.watch = {**self.watch, kind: w._replace(far=w.far + 1)}
        status, nis, dx, P = self._gated_update(residual, H, R, dof)
        if status == 2:
            self.n_rejected += 1
            return UpdateResult(kind, t_s, float("inf"), False, residual)
        self.last_nis = nis
        if status == 1:
            w = lockout.gated(self.watch.get(kind, lockout.Watch()), t_s)
            if not lockout.locked_out(w, t_s, self.lockout_rule):
                self.n_rejected += 1
                self.stats = {**self.stats, kind: (acc, gated + 1, nis_sum)}
                self.watch = {**self.watch, kind: w}
                return UpdateResult(kind, t_s, nis, False, residual)
            P_infl, k = lockout.inflation(self.P, np.asarray(H, float), np.asarray(R, float), residual, self.layout,
                                          self.lockout_rule.target_nis_per_dof, self._P0_diag())
            if not math.isfinite(k):         # the nav states cannot explain it: refused, no recovery (lockout)
                self.n_rejected += 1
                self.stats = {**self.stats, kind: (acc, gated + 1, nis_sum)}
                self.watch = {**self.watch, kind: lockout.unexplained(w)}
                return UpdateResult(kind, t_s, nis, False, residual)
            self.P = P_infl
            self.watch = {**self.watch, kind: lockout.recovered(w, t_s, k)}
            status, nis, dx, P = self._gated_update(residual, H, R, dof)
            self.last_nis = nis
            if status != 0:                  # not brought back inside the gate (k at its cap): still refused
                self.n_rejected += 1
                self.stats = {**self.stats, kind: (acc, gated + 1, nis_sum)}
                return UpdateResult(kind, t_s, nis, False, residual)
        w = self.watch.get(kind)
        if w is not None and w.run:
            self.watch = {**self.watch, kind: lockout.accepted(w)}
        self.stats = {**self.stats, kind: (acc + 1, gated, nis_sum + nis / dof)}
        self.P = P
        self.inject(dx)
        self.epoch_dx = dx if self.epoch_dx is None else self.epoch_dx + dx
        self.n_updates += 1
        return UpdateResult(kind, t_s, nis, True, residual)

    def _P0_diag(self) -> np.ndarray:
        """The configured initial variances (the lock-out recovery's bound), cached per configuration."""
        if getattr(self, "_p0_cfg", None) is not self.cfg:
            self._p0_cfg, self._p0 = self.cfg, np.diag(self.cfg.initial_covariance()).copy()
        return self._p0

    def _gated_update(self, residual, H, R, dof):
        """(status, nis, dx, P') of the gated Joseph update, compiled or numpy."""
        if self.fast:
            status, nis, dx, P = fast_update.joseph_update(
                self.P, np.ascontiguousarray(H, dtype=float), np.ascontiguousarray(R, dtype=float),
                np.ascontiguousarray(residual), float(self.gate_threshold(dof)))
            return status, float(nis), dx, P
        return self._update_reference(residual, H, R, dof)

    def _update_reference(self, residual, H, R, dof):
        """The numpy form of ``fast.update.joseph_update``: (status, nis, dx, P')."""
        S = H @ self.P @ H.T + R
        S = 0.5 * (S + S.T)
        try:
            S_inv_r = np.linalg.solve(S, residual)
        except np.linalg.LinAlgError:
            return 2, float("inf"), None, self.P
        nis = float(residual @ S_inv_r)
        if not np.isfinite(nis) or nis > self.gate_threshold(dof):
            return 1, nis, None, self.P
        K = np.linalg.solve(S, H @ self.P).T          # P H^T S^-1 (S symmetric)
        dx = K @ residual
        I_KH = np.eye(self.layout.dim) - K @ H
        P = I_KH @ self.P @ I_KH.T + K @ R @ K.T        # Joseph form
        return 0, nis, dx, 0.5 * (P + P.T)

    def inject(self, dx: np.ndarray) -> None:
        """Correct the nominal state with an error estimate dx (estimate -
        truth): the frame's att/vel/pos, then every block value minus its error."""
        inject = self.frame.fast_inject if self.fast else self.frame.inject
        self.x_nav = inject(self.x_nav, dx[:9])
        if len(self.values):
            self.values = self.values - dx[9:]
