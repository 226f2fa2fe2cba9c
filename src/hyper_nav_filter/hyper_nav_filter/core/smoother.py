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


def rts_smooth(history: list, cfg: FilterConfig, filt: ErrorStateKF) -> list[Solution]:
    """Smoothed solutions for every epoch of a forward pass (FusionEngine
    with keep_history=True; pass ``engine.full_history()`` and the forward
    filter ``engine.kf``).

    The recursion runs in the forward filter's own error frame (its
    snapshots, ``Phi``, ``P_prior`` and corrections are in it); the filter is
    used to apply the corrections and is left restored to its final state.
    The returned solutions are the geodetic/ENU view with the ENU covariance."""
    n = len(history)
    if n == 0:
        return []
    final = filt.snapshot()
    out: list[Solution | None] = [None] * n
    e = np.zeros(cfg.layout.dim)
    last = history[-1]
    Ps = last.snap.P
    out[-1] = _solution(filt, last, filt.snapshot_state(last.snap), filt.P_enu(last.snap), last.snap.values)
    for k in range(n - 2, -1, -1):
        h, h1 = history[k], history[k + 1]
        P_post = h.snap.P
        c_next = 0.0 if h1.dx is None else -h1.dx
        # A = P+ Phi^T (P-)^-1  computed as solve(P-, Phi P+)^T (P- symmetric positive definite)
        A = cho_solve(cho_factor(h1.P_prior), h1.Phi @ P_post).T
        e = A @ (e + c_next)
        Ps = P_post + A @ (Ps - h1.P_prior) @ A.T
        Ps = 0.5 * (Ps + Ps.T)
        filt.restore(h.snap)
        filt.inject(-e)                        # move the filtered estimate by +e
        filt.P = Ps
        out[k] = _solution(filt, h, filt.state, filt.P_enu(), filt.values)
    filt.restore(final)
    return out


def _solution(filt, ep, state, P, values) -> Solution:
    dth, dv = filt.corrected(ep.imu.dtheta_b_rad, ep.imu.dvel_b_mps, ep.imu.dt_s, values)
    return Solution(ep.imu.t_s, state, P, 0, ep.snap.n_updates, ep.snap.n_rejected, ep.snap.last_nis,
                    dth / ep.imu.dt_s, dv / ep.imu.dt_s)
