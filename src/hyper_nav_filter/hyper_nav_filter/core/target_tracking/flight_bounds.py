"""Which lower bound holds for one fixed flight (issue 40), numpy float64.

The tracking Monte Carlo of seed 002 flies *one* trajectory per scenario with
a deterministic maneuver and randomizes only the radar noise and the
hand-over error. Three bounds, and what each bounds:

* **Known maneuver** (``augmented.known_bound``): the Bayesian bound whose
  prior is the one the flights follow (the maneuver is not random: a point
  mass at the truth) with the hand-over error ~ N(0, P0). It holds for every
  estimator on the fixed flight; nothing tighter does (an estimator built
  around this very maneuver attains it).
* **Random-walk PCRB** (``augmented.augmented_bound``, Tichavsky, Muravchik
  and Nehorai 1998): the parameters a_v, a_l, c_d as random walks. It bounds
  the MSE *averaged over parameter paths drawn from those walks*. On one
  fixed path it does not hold: for a linear-Gaussian model the optimal
  filter's error splits into a part driven by the radar noise and the
  hand-over error (covariance C_k, whatever the path) and a part driven by
  the path's increments w_k (mean m_k); the PCRB is C_k + E_w[m m^T], a fixed
  path gives C_k + m_k m_k^T, smaller whenever the path moves less than a
  typical draw (``fixed_path_error``). A filter on draws from the walks stays
  above it (tested, ``bayesian_draws``).
* **Windowed CRB** (``windowed_crb``): the maneuver parameters as unknown
  deterministic offsets from the truth's, one constant offset per window of
  stated length, no prior on them; the hand-over estimate is a measurement of
  the initial kinematic state with covariance P0. The family "truth + offsets"
  contains the flight for every window length, so the bound holds on the fixed
  flight for every estimator unbiased over that family (the Cramer-Rao
  inequality; a biased estimator, e.g. one whose prior favours this maneuver,
  can go below it, and on seed 002 every filter does: they all hold a prior on
  the maneuver). Shorter windows: a larger family, a larger bound.

All recursions are the Kalman filter's covariance recursion of the
linearized model (Jacobians along the truth, the usual approximation), so on a
linear-Gaussian model each bound is the Kalman filter's covariance exactly
(tested on a toy model, ``test_flight_bounds``).
"""
from __future__ import annotations

import numpy as np
from scipy import stats


def kalman_bound(F, P0, H, R, Q):
    """Covariance recursion P_k (N, n, n) and gains K_k (N, n, m) of the
    Kalman filter of x_{k+1} = F_k x_k + w_k, w_k ~ N(0, Q_k), z_k = H x_k +
    v_k, v_k ~ N(0, R), prior N(., P0) updated with z_0. For Gaussian noise
    this is the PCRB recursion (J_{k+1} = (F J_k^-1 F^T + Q)^-1 + H^T R^-1 H).
    Q (n, n) or (N-1, n, n)."""
    F, H, R = np.asarray(F, float), np.asarray(H, float), np.asarray(R, float)
    Q = np.asarray(Q, float)
    n, N = F.shape[-1], len(F) + 1
    P = np.empty((N, n, n))
    K = np.empty((N, n, H.shape[0]))
    Pp = np.asarray(P0, float)
    for k in range(N):
        if k > 0:
            Pp = F[k - 1] @ P[k - 1] @ F[k - 1].T + (Q[k - 1] if Q.ndim == 3 else Q)
        S = H @ Pp @ H.T + R
        K[k] = np.linalg.solve(S, H @ Pp).T
        IKH = np.eye(n) - K[k] @ H
        Pk = IKH @ Pp @ IKH.T + K[k] @ R @ K[k].T          # Joseph form
        P[k] = 0.5 * (Pk + Pk.T)
    return P, K


def windowed_crb(F, P0_kin, H, R, n_kin: int, window_id, diffuse_sigma: float = 1.0e4):
    """(N, n, n) CRB of the state with the last n - n_kin components (the
    maneuver parameters) unknown deterministic offsets, constant over each
    window: ``window_id`` (N-1,) int, the window of each propagation step; a
    new window starts a fresh offset with no prior (diffuse, sigma
    ``diffuse_sigma`` in the state's units: the limit is reached to < 1e-4
    relative at 1e4, tested), uncorrelated with the state. P0_kin: the
    hand-over covariance of the kinematic states. Causal (a filtering bound:
    data up to epoch k)."""
    F = np.asarray(F, float)
    n = F.shape[-1]
    wid = np.asarray(window_id)
    d2 = float(diffuse_sigma) ** 2
    P0 = np.zeros((n, n))
    P0[:n_kin, :n_kin] = np.asarray(P0_kin, float)[:n_kin, :n_kin]
    P0[n_kin:, n_kin:] = d2 * np.eye(n - n_kin)
    H, R = np.asarray(H, float), np.asarray(R, float)
    out = np.empty((len(F) + 1, n, n))
    Pp = P0
    for k in range(len(F) + 1):
        if k > 0:
            Pk = out[k - 1].copy()
            if k - 1 > 0 and wid[k - 1] != wid[k - 2]:        # a new window: a fresh unknown offset
                Pk[:n_kin, n_kin:] = 0.0
                Pk[n_kin:, :n_kin] = 0.0
                Pk[n_kin:, n_kin:] = d2 * np.eye(n - n_kin)
            Pp = F[k - 1] @ Pk @ F[k - 1].T
        S = H @ Pp @ H.T + R
        Kk = np.linalg.solve(S, H @ Pp).T
        IKH = np.eye(n) - Kk @ H
        Pn = IKH @ Pp @ IKH.T + Kk @ R @ Kk.T
        out[k] = 0.5 * (Pn + Pn.T)
    return out


def window_ids(t_s, window_s: float):
    """(N-1,) window index of each propagation step (t_k -> t_{k+1}) for
    windows of ``window_s`` seconds from t_0 (inf: one window)."""
    t = np.asarray(t_s, float)
    if not np.isfinite(window_s):
        return np.zeros(len(t) - 1, int)
    return np.floor((t[:-1] - t[0]) / window_s + 1e-9).astype(int)


def fixed_path_error(F, K, H, R, P0, m0, drive):
    """Error x - x_hat of the linear filter with gains K_k (``kalman_bound``)
    on one fixed path: x_{k+1} = F_k x_k + drive_k (drive (N-1, n): the
    path's own increments, e.g. the truth's parameter steps and the model
    mismatch), z_k = H x_k + v_k, the filter's prior error at k = 0 with mean
    m0 and covariance P0. Returns the covariance C (N, n, n), due to the radar
    noise and the hand-over error, and the mean m (N, n), due to the path:
    MSE = C + m m^T."""
    F, K, H, R = (np.asarray(a, float) for a in (F, K, H, R))
    n, N = F.shape[-1], len(F) + 1
    C, m = np.empty((N, n, n)), np.empty((N, n))
    Cp, mp = np.asarray(P0, float), np.asarray(m0, float)
    for k in range(N):
        if k > 0:
            Cp = F[k - 1] @ C[k - 1] @ F[k - 1].T
            mp = F[k - 1] @ m[k - 1] + drive[k - 1]
        IKH = np.eye(n) - K[k] @ H
        Ck = IKH @ Cp @ IKH.T + K[k] @ R @ K[k].T
        C[k] = 0.5 * (Ck + Ck.T)
        m[k] = IKH @ mp
    return C, m


def random_walk_paths(p0_mean, init_sigma, q_steps, rng, draws: int):
    """(draws, N, n_par) paths p_{k+1} = p_k + w_k, w_k ~ N(0, diag(q_steps[k]^2))
    (q_steps (N-1, n_par): the per-step sigma), p_0 ~ N(p0_mean, diag(init_sigma^2))."""
    q = np.asarray(q_steps, float)
    p0 = np.asarray(p0_mean, float) + np.asarray(init_sigma, float) * rng.standard_normal((draws, q.shape[1]))
    w = q[None] * rng.standard_normal((draws,) + q.shape)
    return p0[:, None] + np.concatenate([np.zeros((draws, 1, q.shape[1])), np.cumsum(w, axis=1)], axis=1)


def rmse_interval(err, level: float = 0.95):
    """RMSE over runs and epochs of err (runs, T, ...) and its Monte Carlo
    confidence interval: the per-run mean squares are independent; a
    Student-t interval on their mean, square-rooted. Returns (rmse, lo, hi),
    each (...)."""
    ms = np.mean(np.asarray(err, float) ** 2, axis=1)          # (runs, ...)
    r = ms.shape[0]
    mean = ms.mean(0)
    half = stats.t.ppf(0.5 + level / 2, r - 1) * ms.std(0, ddof=1) / np.sqrt(r) if r > 1 else np.inf * mean
    return np.sqrt(mean), np.sqrt(np.maximum(mean - half, 0.0)), np.sqrt(mean + half)


def rms_over_time(P, scale):
    """sqrt(mean over epochs of diag P) in physical units, P (N, n, n) scaled, scale (>= n)."""
    var = np.diagonal(P, axis1=1, axis2=2)
    return np.sqrt(np.mean(var, axis=0)) * np.asarray(scale, float)[: var.shape[1]]
