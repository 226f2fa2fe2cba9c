"""Error-state Kalman filter on the ENU strapdown INS.

The filter owns the nominal state and the error covariance. ``predict``
runs one mechanization step and propagates P; ``update`` takes any
measurement model's (residual, H, R), gates it with a chi-square test on the
normalized innovation squared, applies the Joseph-form update and injects
the error estimate into the nominal state (then resets the error to zero).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from . import earth, mechanization
from .attitude import rotvec_to_C
from .config import FilterConfig
from .elastic_lever_arm import LeverArmCompensator, ModalModel
from .error_model import discretize, system_matrices
from .nav_state import ImuSample, NavState
from .state_layout import BLOCK_SIZES, EXTRA_BLOCKS


@dataclass
class UpdateResult:
    kind: str
    t_s: float
    nis: float
    accepted: bool
    residual: np.ndarray


@dataclass
class FilterSnapshot:
    """Everything needed to resume the filter at an epoch (for re-processing)."""
    state: NavState
    P: np.ndarray
    imu_prev: ImuSample | None
    vel_prev_enu_mps: np.ndarray | None
    n_updates: int
    n_rejected: int
    last_nis: float
    stats: dict


class ErrorStateKF:
    def __init__(self, config: FilterConfig, state: NavState, P0: np.ndarray):
        self.cfg = config
        self.layout = config.layout
        self.state = state
        self.P = P0.copy()
        self.imu_prev: ImuSample | None = None
        self.vel_prev_enu_mps: np.ndarray | None = None
        self.n_updates = 0
        self.n_rejected = 0
        self.last_nis = float("nan")
        # per measurement kind: [accepted, rejected by the gate, sum of NIS]
        self.stats: dict[str, list] = {}
        # per-epoch quantities the RTS smoother needs (see smoother.py)
        self.last_Phi = np.eye(self.layout.dim)
        self.P_prior = self.P.copy()
        self.epoch_dx = np.zeros(self.layout.dim)
        self._gate = {}
        self._noise = config.noise_psd(self.layout)
        self._lever = LeverArmCompensator(ModalModel.from_config(config)) if self.layout.has("lev") else None

    # ---- bookkeeping for re-processing -------------------------------------
    def snapshot(self) -> FilterSnapshot:
        return FilterSnapshot(self.state.copy(), self.P.copy(), self.imu_prev,
                              None if self.vel_prev_enu_mps is None else self.vel_prev_enu_mps.copy(),
                              self.n_updates, self.n_rejected, self.last_nis,
                              {k: list(v) for k, v in self.stats.items()})

    def restore(self, snap: FilterSnapshot) -> None:
        self.state = snap.state.copy()
        self.P = snap.P.copy()
        self.imu_prev = snap.imu_prev
        self.vel_prev_enu_mps = None if snap.vel_prev_enu_mps is None else snap.vel_prev_enu_mps.copy()
        self.n_updates, self.n_rejected, self.last_nis = snap.n_updates, snap.n_rejected, snap.last_nis
        self.stats = {k: list(v) for k, v in (snap.stats or {}).items()}

    # ---- predict ----------------------------------------------------------------
    def predict(self, imu: ImuSample) -> None:
        """Mechanize one IMU interval and propagate the covariance. With the
        ``lev`` block the velocity increment is first moved from the IMU
        station to the CG (``_compensate_lever``)."""
        prior = self.state
        wdot, lev1 = None, None
        if self._lever is not None:
            imu, lev1, wdot = self._compensate_lever(imu, prior)
        dth, dv = mechanization.compensate(imu, prior)
        F, G, Qc = system_matrices(prior, dv / imu.dt_s, dth / imu.dt_s, self.layout, self.cfg,
                                    self._noise, wdot, self._lever.model if self._lever else None)
        Phi, Q = discretize(F, G, Qc, imu.dt_s, exact=self._lever is not None)
        self.state = mechanization.propagate(prior, imu, self.imu_prev, self.vel_prev_enu_mps)
        self.state.extra = self._propagate_extra(prior.extra, imu.dt_s, lev1)
        self.vel_prev_enu_mps = prior.vel_enu_mps
        self.imu_prev = imu
        self._propagate_covariance(Phi, Q)

    def _propagate_extra(self, extra: dict, dt_s: float, lev1) -> dict:
        """Nominal values of the optional blocks over one interval, as their
        error models say: the clock bias integrates the drift (b' = d), the
        Markov gyro drift decays (gm' = -gm / T_g), the modes were stepped by
        the lever-arm compensation; scale factors are constants."""
        out = dict(extra)
        if "clk" in out:
            b, d = out["clk"]
            out["clk"] = np.array([b + d * dt_s, d])
        if "gm" in out:
            out["gm"] = out["gm"] * np.exp(-dt_s / self.cfg.gyro_markov_tau_s)
        if lev1 is not None:
            out["lev"] = lev1
        return out

    def _compensate_lever(self, imu: ImuSample, prior: NavState):
        """Dynamic lever-arm compensation (seed 000 Fig. 3): propagate the
        nominal modal state over the interval and remove the lever-arm
        velocity increment from the raw sample. Returns (compensated sample,
        modal state at its end, angular acceleration)."""
        dth_c, dv_c = prior.compensate(imu.dtheta_b_rad, imu.dvel_b_mps, imu.dt_s)
        w_prev = None
        if self.imu_prev is not None:
            w_prev = prior.compensate(self.imu_prev.dtheta_b_rad, self.imu_prev.dvel_b_mps,
                                      self.imu_prev.dt_s)[0] / self.imu_prev.dt_s
        lev = prior.extra.get("lev")
        if lev is None:          # first interval: start at the static deflection
            lev = self._lever.model.equilibrium(dv_c / imu.dt_s)
            prior.extra["lev"] = lev
        dv_cg, lev1, _, wdot = self._lever.compensate(lev, dth_c, dv_c, imu.dt_s, w_prev)
        # removed from the raw increment (the scale-factor product s * dv_lever is neglected)
        out = ImuSample(imu.t_s, imu.dt_s, imu.dtheta_b_rad, imu.dvel_b_mps - (dv_c - dv_cg))
        return out, lev1, wdot

    def _propagate_covariance(self, Phi, Q) -> None:
        """P = Phi P Phi^T + Q (symmetrised); keep Phi and the prior for the smoother."""
        P = Phi @ self.P @ Phi.T + Q
        self.P = 0.5 * (P + P.T)
        self.last_Phi, self.P_prior = Phi, self.P.copy()
        self.epoch_dx = np.zeros(self.layout.dim)

    # ---- update -----------------------------------------------------------------
    def model(self, meas, ctx):
        """(residual, H, R) of a measurement for the current state; a filter in
        another mechanization frame overrides this to use its own models."""
        return meas.model(self.state, self.layout, ctx)

    def gate_threshold(self, dof: int) -> float:
        if dof not in self._gate:
            self._gate[dof] = float(chi2.ppf(self.cfg.gate_probability, dof))
        return self._gate[dof]

    def update(self, kind: str, t_s: float, residual, H, R) -> UpdateResult:
        """Apply a measurement: residual = predicted - measured, H its Jacobian
        w.r.t. the error state, R its covariance."""
        residual = np.asarray(residual, dtype=float)
        S = H @ self.P @ H.T + R
        S = 0.5 * (S + S.T)
        try:
            S_inv_r = np.linalg.solve(S, residual)
        except np.linalg.LinAlgError:
            self.n_rejected += 1
            return UpdateResult(kind, t_s, float("inf"), False, residual)
        nis = float(residual @ S_inv_r)
        self.last_nis = nis
        st = self.stats.setdefault(kind, [0, 0, 0.0])
        if not np.isfinite(nis) or nis > self.gate_threshold(len(residual)):
            self.n_rejected += 1
            st[1] += 1
            return UpdateResult(kind, t_s, nis, False, residual)
        st[0] += 1
        st[2] += nis / len(residual)
        K = np.linalg.solve(S, H @ self.P).T          # P H^T S^-1 (S symmetric)
        dx = K @ residual
        I_KH = np.eye(self.layout.dim) - K @ H
        P = I_KH @ self.P @ I_KH.T + K @ R @ K.T        # Joseph form
        self.P = 0.5 * (P + P.T)
        self._inject(dx)
        self.epoch_dx = self.epoch_dx + dx
        self.n_updates += 1
        return UpdateResult(kind, t_s, nis, True, residual)

    def inject(self, dx: np.ndarray) -> None:
        """Public form of the correction: nominal state minus error ``dx``."""
        self._inject(dx)

    def _inject(self, dx: np.ndarray) -> None:
        """Correct the nominal state with the error estimate (estimate - truth)."""
        lay, s = self.layout, self.state
        phi = dx[lay.sl("att")]
        s.C_b_n = rotvec_to_C(phi) @ s.C_b_n        # C_true = (I + [phi x]) C_est
        s.vel_enu_mps = s.vel_enu_mps - dx[lay.sl("vel")]
        d_e, d_n, d_u = dx[lay.sl("pos")]
        r_m, r_n = earth.radii(s.lat_rad)
        s.lat_rad -= d_n / (r_m + s.alt_m)
        s.lon_rad -= d_e / ((r_n + s.alt_m) * np.cos(s.lat_rad))
        s.alt_m -= d_u
        if lay.has("bg"):
            s.gyro_bias_b_radps = s.gyro_bias_b_radps - dx[lay.sl("bg")]
        if lay.has("ba"):
            s.accel_bias_b_mps2 = s.accel_bias_b_mps2 - dx[lay.sl("ba")]
        for name in EXTRA_BLOCKS:
            if lay.has(name):
                s.extra[name] = s.extra.get(name, np.zeros(BLOCK_SIZES[name])) - dx[lay.sl(name)]
