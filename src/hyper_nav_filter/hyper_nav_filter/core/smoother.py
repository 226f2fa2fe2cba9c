"""Fixed-interval Rauch-Tung-Striebel smoother for the error-state filter,
run offline on a replayed bag after the forward pass.

With the forward filter's post-update state x_k+, covariance P_k+, the
transition Phi_{k+1} and prior P_{k+1}- of the next epoch, and the correction
c_{k+1} = x_{k+1}+ - x_{k+1}- that its updates applied (error-state form,
c = -dx because errors are estimate minus truth):

    A_k   = P_k+ Phi_{k+1}^T (P_{k+1}-)^-1
    e_k   = A_k (e_{k+1} + c_{k+1})            (smoothed minus filtered)
    P_k^s = P_k+ + A_k (P_{k+1}^s - P_{k+1}-) A_k^T

and the smoothed state is x_k+ corrected by e_k (Rauch, Tung & Striebel
1965; the error-state form as in Groves, 2nd ed., section 3.4.5).
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from .config import FilterConfig
from .eskf import ErrorStateKF
from .fusion import Solution


def rts_smooth(history: list, cfg: FilterConfig) -> list[Solution]:
    """Smoothed solutions for every epoch of a forward pass (FusionEngine
    with keep_history=True; pass ``engine.full_history()``)."""
    n = len(history)
    if n == 0:
        return []
    dim = cfg.layout.dim
    out: list[Solution | None] = [None] * n
    e = np.zeros(dim)
    Ps = history[-1].snap.P.copy()
    out[-1] = _solution(history[-1], history[-1].snap.state.copy(), Ps)
    helper = ErrorStateKF(cfg, history[-1].snap.state.copy(), Ps)
    for k in range(n - 2, -1, -1):
        h, h1 = history[k], history[k + 1]
        P_post = h.snap.P
        c_next = -h1.dx
        # A = P+ Phi^T (P-)^-1  computed as solve(P-, Phi P+)^T (P- symmetric positive definite)
        A = cho_solve(cho_factor(h1.P_prior), h1.Phi @ P_post).T
        e = A @ (e + c_next)
        Ps = P_post + A @ (Ps - h1.P_prior) @ A.T
        Ps = 0.5 * (Ps + Ps.T)
        helper.state = h.snap.state.copy()
        helper.inject(-e)                      # move the filtered estimate by +e
        out[k] = _solution(h, helper.state, Ps)
    return out


def _solution(ep, state, P) -> Solution:
    return Solution(ep.imu.t_s, state, P, 0, ep.snap.n_updates, ep.snap.n_rejected, ep.snap.last_nis,
                    ep.imu.dtheta_b_rad / ep.imu.dt_s - state.gyro_error_b_radps(),
                    ep.imu.dvel_b_mps / ep.imu.dt_s - state.accel_bias_b_mps2)
