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


def rts_smooth(history: list, cfg: FilterConfig, filt: ErrorStateKF | None = None) -> list[Solution]:
    """Smoothed solutions for every epoch of a forward pass (FusionEngine
    with keep_history=True; pass ``engine.full_history()``).

    The recursion runs in the forward filter's own error frame: ENU for
    ``ErrorStateKF``, LCI for ``LciErrorStateKF`` (its snapshots carry the
    LCI covariance, and ``last_Phi``/``P_prior``/``epoch_dx`` are LCI). Pass
    the forward filter as ``filt`` (``engine.kf``; required for LCI, whose
    launch frame it holds): it is used to apply the corrections and is left
    restored to its final state. The returned solutions are in the ENU view."""
    n = len(history)
    if n == 0:
        return []
    if filt is None:
        if cfg.mechanization_frame != "ENU":
            raise ValueError("rts_smooth: pass the forward filter (engine.kf) for a "
                             f"{cfg.mechanization_frame} filter")
        filt = ErrorStateKF(cfg, history[-1].snap.state.copy(), history[-1].snap.P.copy())
    final = filt.snapshot()
    own_P = (lambda snap: snap.P_lci) if hasattr(final, "P_lci") else (lambda snap: snap.P)
    out: list[Solution | None] = [None] * n
    e = np.zeros(cfg.layout.dim)
    Ps = own_P(history[-1].snap).copy()
    out[-1] = _solution(history[-1], history[-1].snap.state.copy(), history[-1].snap.P.copy())
    for k in range(n - 2, -1, -1):
        h, h1 = history[k], history[k + 1]
        P_post = own_P(h.snap)
        c_next = -h1.dx
        # A = P+ Phi^T (P-)^-1  computed as solve(P-, Phi P+)^T (P- symmetric positive definite)
        A = cho_solve(cho_factor(h1.P_prior), h1.Phi @ P_post).T
        e = A @ (e + c_next)
        Ps = P_post + A @ (Ps - h1.P_prior) @ A.T
        Ps = 0.5 * (Ps + Ps.T)
        filt.restore(h.snap)
        filt.inject(-e)                        # move the filtered estimate by +e
        filt.P = Ps
        out[k] = _solution(h, filt.state.copy(), filt.P_enu() if hasattr(filt, "P_enu") else Ps.copy())
    filt.restore(final)
    return out


def _solution(ep, state, P) -> Solution:
    return Solution(ep.imu.t_s, state, P, 0, ep.snap.n_updates, ep.snap.n_rejected, ep.snap.last_nis,
                    ep.imu.dtheta_b_rad / ep.imu.dt_s - state.gyro_error_b_radps(),
                    ep.imu.dvel_b_mps / ep.imu.dt_s - state.accel_bias_b_mps2)
