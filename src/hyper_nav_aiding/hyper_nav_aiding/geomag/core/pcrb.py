"""Posterior Cramer-Rao bound (PCRB) of the INS/geomagnetic navigation error.

The bound answers: given this map, flight, IMU and map noise, how well can
*any* estimator know the position? It is computed for the full INS error
state (attitude, velocity, position, gyro/accelerometer bias and scale
factor: ``hyper_nav_filter``'s error model, the ENU frame's 9 x 9 core and
the blocks' couplings (``frames.enu``, ``system_model``), evaluated along the
true trajectory) with

* a Gaussian prior P0 (the initial errors and IMU error magnitudes);
* the IMU white noise (ARW, VRW) as process noise, biases and scale factors
  as random constants;
* measurements, each a linear row of the error state plus noise:
  total intensity  z = grad F . dr + d(r) + n   (seed 003 eqs. 9-11, with
  the vertical gradient), barometric height z = dh + n_b, and optionally
  the three field components (attitude enters: z_n = -[B x] phi + dB/dr dr
  + u d + n);
* the map error d(r): a Gaussian process in position (covariance
  sigma^2 exp(-|r_i - r_j|^2 / (2 L^2)), the simulator's ``MapErrorField``)
  or white (the other reading of the paper's error levels).

For a linear-Gaussian model the PCRB equals the covariance of the
conditional mean given all measurements so far (the Kalman filter's when the
noise is white). With a correlated map error the measurement noise is not
white, so the bound is computed in batch form, exactly:

    P_k|1:k = P_k - Cov(x_k, z_1:k) Cov(z_1:k)^-1 Cov(z_1:k, x_k)

with an incrementally grown Cholesky factor of Cov(z_1:k) (P_k is the
unconditioned covariance, Cov(x_k, z_j) = Phi(k, j) P_j H_j^T). The map's
gradient is taken at the true position: over this map the field is a plane
to within 0.1 % across the error ellipse (the gradient changes by
~1.1 nT/km over 800 km), so the expected Fisher information of the map
equals its value at the truth. Cost for seed 003 (21 states, 790 epochs):
about 2 s.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import cholesky, solve_triangular

from hyper_nav_gnss import earth
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.frames.enu import EnuFrame
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_filter.core.system_model import discretize, system_model

SQRT_2_OVER_PI = float(np.sqrt(2.0 / np.pi))     # E|e| / sigma of a zero-mean Gaussian


@dataclass
class ErrorTransitions:
    """Error-state transitions between consecutive epochs along the truth."""
    t_s: np.ndarray           # (N,) epochs
    Phi: np.ndarray           # (N, n, n); Phi[k] takes epoch k-1 to k (Phi[0] = I)
    Q: np.ndarray             # (N, n, n) process noise over the same interval


def transitions_along_truth(traj, t_s, cfg: FilterConfig, substep_s: float = 0.1) -> ErrorTransitions:
    """Phi and Q of ``cfg``'s error model between consecutive epochs ``t_s``,
    chained over sub-steps of about ``substep_s`` with the true state,
    specific force and body rate (exact increments over each sub-step)."""
    t_s = np.asarray(t_s, float)
    n = cfg.layout.dim
    sm = system_model(cfg)
    tr0 = traj.truth(t_s[:1])
    frame = EnuFrame(cfg, NavState(float(t_s[0]), float(tr0.lat_rad[0]), float(tr0.lon_rad[0]), float(tr0.alt_m[0]),
                                   np.asarray(tr0.vel_enu_mps[0], float), np.asarray(tr0.C_b_n[0], float)))
    Phi = np.tile(np.eye(n), (len(t_s), 1, 1))
    Q = np.zeros((len(t_s), n, n))
    for k in range(1, len(t_s)):
        dt = t_s[k] - t_s[k - 1]
        m = max(1, int(round(dt / substep_s)))
        h = dt / m
        t_end = t_s[k - 1] + h * np.arange(1, m + 1)
        dth, dv = traj.imu_increments(t_end, h)
        tr = traj.truth(t_end - 0.5 * h)
        for j in range(m):
            st = NavState(float(t_end[j]), float(tr.lat_rad[j]), float(tr.lon_rad[j]), float(tr.alt_m[j]),
                          np.asarray(tr.vel_enu_mps[j], float), np.asarray(tr.C_b_n[j], float))
            w, f = dth[j] / h, dv[j] / h
            F9, C = frame.error_dynamics(frame.nominal(st), float(t_end[j]), f, w)
            F, G, qc = sm.matrices(F9, C, w, f)
            ph, q = discretize(F, G, qc, h, sm.exact)
            Phi[k] = ph @ Phi[k]
            Q[k] = ph @ Q[k] @ ph.T + q
    return ErrorTransitions(t_s, Phi, Q)


@dataclass
class Rows:
    """Measurements at one epoch: z = H x + c d_k + n, n ~ N(0, diag(r))."""
    H: np.ndarray             # (b, n)
    r: np.ndarray             # (b,) white-noise variances
    c: np.ndarray | None = None   # (b,) coefficients of the epoch's map error d_k (None: no map error)


def linear_gaussian_bound(P0: np.ndarray, tr: ErrorTransitions, rows: list[Rows | None],
                          map_error_cov=None) -> np.ndarray:
    """Bound covariances P_k|1:k, shape (N, n, n), for measurements
    ``rows[k]`` at epoch k (None: none). ``map_error_cov(i, j)`` returns the
    covariance of the map errors of epochs i (array) and j (scalar), or None
    for no map error; white map error is a diagonal one."""
    N, n = len(tr.t_s), P0.shape[0]
    M = sum(0 if r is None else len(r.r) for r in rows)
    L = np.zeros((M, M))
    Sxz = np.zeros((n, M))         # Cov(x_k, z_j), j <= k
    Y = np.zeros((M, n))           # L^-1 Cov(z, x_k)
    coef = np.zeros(M)             # map-error coefficient of each row
    ep = np.zeros(M, dtype=int)    # epoch of each row
    m = 0
    P = P0.copy()
    out = np.empty((N, n, n))
    for k in range(N):
        if k > 0:
            P = tr.Phi[k] @ P @ tr.Phi[k].T + tr.Q[k]
            Sxz[:, :m] = tr.Phi[k] @ Sxz[:, :m]
            Y[:m] = Y[:m] @ tr.Phi[k].T
        r = rows[k]
        if r is not None and len(r.r):
            b = len(r.r)
            c = np.zeros(b) if r.c is None else np.asarray(r.c, float)
            S_nn = r.H @ P @ r.H.T + np.diag(r.r)
            S_on = (r.H @ Sxz[:, :m]).T          # (m, b): Cov(z_old, z_new)
            if map_error_cov is not None and np.any(c != 0):
                S_nn += np.outer(c, c) * map_error_cov(np.array([k]), k)[0]
                if m:
                    S_on += np.outer(coef[:m] * map_error_cov(ep[:m], k), c)
            L21 = solve_triangular(L[:m, :m], S_on, lower=True, check_finite=False).T if m else np.zeros((b, 0))
            L22 = cholesky(S_nn - L21 @ L21.T, lower=True)
            Sxz_new = P @ r.H.T
            L[m:m + b, :m] = L21
            L[m:m + b, m:m + b] = L22
            Y[m:m + b] = solve_triangular(L22, Sxz_new.T - L21 @ Y[:m], lower=True, check_finite=False)
            Sxz[:, m:m + b] = Sxz_new
            coef[m:m + b] = c
            ep[m:m + b] = k
            m += b
        out[k] = P - Y[:m].T @ Y[:m]
    return out


def riccati_bound(P0: np.ndarray, tr: ErrorTransitions, rows: list[Rows | None]) -> np.ndarray:
    """The same bound by the Kalman recursion, valid for white noise only
    (c ignored): a check of ``linear_gaussian_bound`` and a fast path."""
    P = P0.copy()
    out = np.empty((len(tr.t_s),) + P0.shape)
    for k in range(len(tr.t_s)):
        if k > 0:
            P = tr.Phi[k] @ P @ tr.Phi[k].T + tr.Q[k]
        r = rows[k]
        if r is not None and len(r.r):
            S = r.H @ P @ r.H.T + np.diag(r.r)
            K = np.linalg.solve(S, r.H @ P).T
            P = P - K @ S @ K.T
            P = 0.5 * (P + P.T)
        out[k] = P
    return out


def gaussian_map_error_cov(positions_ecef_m: np.ndarray, sigma_nT: float, corr_length_m: float):
    """Covariance function of the simulator's map error between epochs
    (``MapErrorField``: sigma^2 exp(-d^2 / (2 L^2)) in ECEF distance)."""
    r = np.asarray(positions_ecef_m, float)

    def cov(i, j):
        d2 = np.sum((r[np.asarray(i)] - r[j]) ** 2, axis=-1)
        return sigma_nT**2 * np.exp(-0.5 * d2 / corr_length_m**2)
    return cov


def white_map_error_cov(sigma_nT: float):
    def cov(i, j):
        return np.where(np.asarray(i) == j, sigma_nT**2, 0.0)
    return cov


@dataclass
class HorizontalBound:
    """Horizontal position bound along the flight (1 sigma, metres)."""
    t_s: np.ndarray
    sigma_e_m: np.ndarray
    sigma_n_m: np.ndarray
    sigma_along_m: np.ndarray     # along the horizontal field gradient
    sigma_across_m: np.ndarray

    def window(self, t0: float, t1: float) -> "HorizontalBound":
        k = (self.t_s >= t0 - 1e-9) & (self.t_s <= t1 + 1e-9)
        return HorizontalBound(self.t_s[k], self.sigma_e_m[k], self.sigma_n_m[k], self.sigma_along_m[k],
                               self.sigma_across_m[k])

    def summary(self) -> dict:
        """RMS over the window and the mean |error| a Gaussian of that sigma has."""
        out = {}
        for name in ("e", "n", "along", "across"):
            s = getattr(self, f"sigma_{name}_m")
            out[f"{name}_rms_m"] = float(np.sqrt(np.mean(s**2)))
            out[f"{name}_mean_abs_m"] = float(SQRT_2_OVER_PI * np.mean(s))
        return out


def horizontal_bound(t_s, P: np.ndarray, pos_slice: slice, grad_en: np.ndarray) -> HorizontalBound:
    """Project the position block on E, N and on the horizontal gradient
    direction (``grad_en`` (N, 2), any scale) and its perpendicular."""
    Pp = P[:, pos_slice, pos_slice][:, :2, :2]
    u = grad_en / np.linalg.norm(grad_en, axis=1, keepdims=True)
    v = np.stack([-u[:, 1], u[:, 0]], axis=1)
    along = np.einsum("ki,kij,kj->k", u, Pp, u)
    across = np.einsum("ki,kij,kj->k", v, Pp, v)
    return HorizontalBound(np.asarray(t_s, float), np.sqrt(Pp[:, 0, 0]), np.sqrt(Pp[:, 1, 1]),
                           np.sqrt(along), np.sqrt(across))


def bound_config(cfg: FilterConfig) -> FilterConfig:
    """The filter config with biases as random constants (the truth model)."""
    return replace(cfg, gyro_bias_tau_s=1e12, accel_bias_tau_s=1e12)


def ecef_of(lat_rad, lon_rad, alt_m) -> np.ndarray:
    return earth.geodetic_to_ecef(np.asarray(lat_rad, float), np.asarray(lon_rad, float), np.asarray(alt_m, float))
