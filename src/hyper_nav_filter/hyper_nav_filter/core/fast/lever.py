"""Elastic lever-arm compensation of one IMU interval in compiled form: the
same closed-form ZOH modal step (``elastic_lever_arm.zoh_matrices``,
``ModalModel.step``) and lever-arm velocity increment (``lever_arm_dvel``)
as ``LeverArmCompensator.compensate`` (one held load per sub-interval of
the load sensor), which stays the reference."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .linalg import cross, mv3


def model_args(m) -> tuple:
    """``compensate``'s model argument from a ``ModalModel`` (float64 arrays)."""
    return tuple(np.ascontiguousarray(a, dtype=np.float64) for a in
                 (m.Y, m.r0_b_m, m.natural_freq_radps, m.damping_ratio, m.load_gain_kg_per_kg, m.deflection_axis_b))


@njit(cache=True)
def compensate(lev, dth, f_load, dt, w_prev, has_prev, model):
    """lev = [q, q'] at the interval start (not finite: the first interval,
    started at the static deflection under this interval's first load,
    ``ModalModel.equilibrium``); dth bias-corrected angle increment; f_load
    (n, 3) the load's specific force over the n equal sub-intervals of the
    interval (n = 1: the interval mean), each held over its sub-interval;
    w_prev the previous interval's corrected mean rate; model = (Y, r0, w_n,
    zeta, load_gain, axis) (``model_args``). Returns (lever-arm velocity
    increment to remove, [q, q'] at the end)."""
    Y, r0, w_n, zeta, load_gain, axis = model
    w_mid = dth / dt
    w_dot = (w_mid - w_prev) / dt if has_prev else np.zeros(3)
    n_sub = f_load.shape[0]
    h = dt / n_sub
    q0, qd0 = np.empty(3), np.empty(3)
    if not np.all(np.isfinite(lev)):
        u0 = axis[0] * f_load[0, 0] + axis[1] * f_load[0, 1] + axis[2] * f_load[0, 2]
        for i in range(3):
            q0[i] = load_gain[i] * u0 / (w_n[i] * w_n[i])
            qd0[i] = 0.0
    else:
        for i in range(3):
            q0[i], qd0[i] = lev[i], lev[3 + i]
    q1, qd1, q_int = q0.copy(), qd0.copy(), np.zeros(3)
    for i in range(3):
        w, z = w_n[i], zeta[i]
        sg = z * w
        wd = w * math.sqrt(1.0 - z * z)
        e = math.exp(-sg * h)
        c, sn = math.cos(wd * h), math.sin(wd * h)
        w2 = w * w
        p_qq = e * (c + sg / wd * sn)
        p_qv = e * sn / wd
        p_vq = -e * w2 / wd * sn
        p_vv = e * (c - sg / wd * sn)
        g_q = (1.0 - p_qq) / w2
        g_v = -p_vq / w2
        s_q = -(p_vq + 2.0 * sg * (p_qq - 1.0)) / w2
        s_v = -((p_vv - 1.0) + 2.0 * sg * p_qv) / w2
        s_u = (h - g_v - 2.0 * sg * g_q) / w2
        x_q, x_v, x_s = q0[i], qd0[i], 0.0
        for j in range(n_sub):
            u = load_gain[i] * (axis[0] * f_load[j, 0] + axis[1] * f_load[j, 1] + axis[2] * f_load[j, 2])
            x_s += s_q * x_q + s_v * x_v + s_u * u
            x_q, x_v = p_qq * x_q + p_qv * x_v + g_q * u, p_vq * x_q + p_vv * x_v + g_v * u
        q1[i], qd1[i], q_int[i] = x_q, x_v, x_s
    w_start, w_end = w_mid - 0.5 * dt * w_dot, w_mid + 0.5 * dt * w_dot
    d_rdot = mv3(Y, qd1 - qd0)          # scalar 3 x 3 products (numba's @ calls BLAS, slower at this size)
    d_r = mv3(Y, q1 - q0)
    r_el = mv3(Y, q_int)
    dw = w_end - w_start
    cent0 = (cross(w_start, cross(w_start, r0)) + 4.0 * cross(w_mid, cross(w_mid, r0))
             + cross(w_end, cross(w_end, r0))) * dt / 6.0
    dv_lever = (d_rdot + 2.0 * cross(w_mid, d_r) + cross(dw, r0) + cross(dw / dt, r_el) + cent0
                + cross(w_mid, cross(w_mid, r_el)))
    out = np.empty(6)
    out[0:3], out[3:6] = q1, qd1
    return dv_lever, out
