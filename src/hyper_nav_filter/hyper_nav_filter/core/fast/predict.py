"""The frame-independent parts of one compiled predict step: IMU error
correction from the blocks' values, F and G from the frame's 9 x 9 core and
the blocks' declared couplings and noises (``core.system_model`` as data),
Phi, Q and the covariance propagation (``system_model.discretize``)."""
from __future__ import annotations

import numpy as np
from numba import njit

from .linalg import expm_taylor, mm3, mm3n, skew


@njit(cache=True)
def corrected(dth, dv, dt, vals, gb, ab, sg, sa):
    """``ErrorStateKF.corrected``: biases (start indices gb, ab into vals)
    removed, then the scale factors (sg, sa) divided out."""
    th = dth.copy()
    v = dv.copy()
    for i in gb:
        th = th - vals[i:i + 3] * dt
    for i in ab:
        v = v - vals[i:i + 3] * dt
    for i in sg:
        th = th / (1.0 + vals[i:i + 3])
    for i in sa:
        v = v / (1.0 + vals[i:i + 3])
    return th, v


@njit(cache=True)
def corrected_pair(dth, dv, dt, pdth, pdt, has_prev, vals, gb, ab, sg, sa):
    """The IMU pre-processing's inputs: this interval's corrected increments
    and the previous interval's corrected mean rate (zeros at the first step),
    both with the current values (``ErrorStateKF._predict_fast``)."""
    th, v = corrected(dth, dv, dt, vals, gb, ab, sg, sa)
    if has_prev:
        th_p, _ = corrected(pdth, dv, pdt, vals, gb, ab, sg, sa)
        return th, v, th_p / pdt
    return th, v, np.zeros(3)


@njit(cache=True)
def _basis(k, w, f, wdot):
    """The k-th body-coupling basis of ``system_model``: I, diag(w), diag(f),
    [w x], [wdot x], [w x]^2."""
    if k == 0:
        return np.eye(3)
    if k == 1:
        return np.diag(w)
    if k == 2:
        return np.diag(f)
    if k == 3:
        return skew(w)
    if k == 4:
        return skew(wdot)
    W = skew(w)
    return mm3(W, W)


@njit(cache=True)
def couple(F, G, C, w, f, wdot, Katt, Kvel, used_att, used_vel, GattM, GvelM):
    """Add the blocks' body couplings C K(w, f, wdot) to the attitude and
    velocity rows of F and the body noises C M to the rows of G (only the
    bases some block uses are formed)."""
    n = F.shape[0]
    for rows in (0, 3):
        K = Katt if rows == 0 else Kvel
        used = used_att if rows == 0 else used_vel
        B = np.zeros((3, n))
        any_term = False
        for k in range(6):
            if used[k]:
                B += mm3n(_basis(k, w, f, wdot), K[k])
                any_term = True
        if any_term:
            F[rows:rows + 3, :] += mm3n(C, B)
    G[0:3, :] += mm3n(C, GattM)
    G[3:6, :] += mm3n(C, GvelM)


@njit(cache=True)
def propagate_covariance(F, G, qc, P, dt, exact):
    """Phi = I + F dt + (F dt)^2 / 2 (or expm) and
    P' = Phi (P + Qh) Phi^T + Qh with Qh = G Qc G^T dt / 2, i.e. the
    trapezoidal Q = (Phi GQG Phi^T + GQG) dt / 2 of ``system_model.discretize``
    added to Phi P Phi^T with two products fewer. Returns (P', Phi)."""
    n = F.shape[0]
    Fdt = F * dt
    if exact:
        Phi = expm_taylor(Fdt)
    else:
        Phi = np.eye(n) + Fdt + 0.5 * (Fdt @ Fdt)
    Gq = G * qc
    Qh = (Gq @ G.T) * (0.5 * dt)
    P1 = Phi @ (P + Qh) @ Phi.T + Qh
    return 0.5 * (P1 + P1.T), Phi


@njit(cache=True)
def imu_terms(dth, dv, dt, pdth, pdv, pdt, has_prev, vals, gb, ab, sg, sa):
    """The corrected increments of this and the previous interval (zeros at
    the first step), the body rate, specific force and angular acceleration
    of this interval (zero acceleration at the first step)."""
    th, v = corrected(dth, dv, dt, vals, gb, ab, sg, sa)
    if has_prev:
        th_p, v_p = corrected(pdth, pdv, pdt, vals, gb, ab, sg, sa)
        wdot = (th / dt - th_p / pdt) / dt
    else:
        th_p, v_p = np.zeros(3), np.zeros(3)
        wdot = np.zeros(3)
    return th, v, th_p, v_p, th / dt, v / dt, wdot
