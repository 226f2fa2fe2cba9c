"""Elastic lever-arm compensation of one IMU interval in compiled form: the
same closed-form ZOH modal step (``elastic_lever_arm.zoh_matrices``,
``ModalModel.step``) and lever-arm velocity increment (``lever_arm_dvel``)
as ``LeverArmCompensator.compensate``, which stays the reference."""
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
def compensate(lev, dth, dv, dt, w_prev, has_prev, model):
    """lev = [q, q'] at the interval start (not finite: the first interval,
    started at the static deflection under this interval's load,
    ``ModalModel.equilibrium``); dth/dv bias-corrected increments; w_prev the
    previous interval's corrected mean rate; model = (Y, r0, w_n, zeta,
    load_gain, axis) (``model_args``). Returns (lever-arm velocity increment
    to remove, [q, q'] at the end)."""
    Y, r0, w_n, zeta, load_gain, axis = model
    w_mid = dth / dt
    w_dot = (w_mid - w_prev) / dt if has_prev else np.zeros(3)
    f = dv / dt
    u_load = axis[0] * f[0] + axis[1] * f[1] + axis[2] * f[2]
    if not np.all(np.isfinite(lev)):
        lev = np.zeros(6)
        for i in range(3):
            lev[i] = load_gain[i] * u_load / (w_n[i] * w_n[i])
    q0, qd0 = lev[0:3], lev[3:6]
    q1, qd1, q_int = np.empty(3), np.empty(3), np.empty(3)
    for i in range(3):
        w, z = w_n[i], zeta[i]
        sg = z * w
        wd = w * math.sqrt(1.0 - z * z)
        e = math.exp(-sg * dt)
        c, sn = math.cos(wd * dt), math.sin(wd * dt)
        w2 = w * w
        p_qq = e * (c + sg / wd * sn)
        p_qv = e * sn / wd
        p_vq = -e * w2 / wd * sn
        p_vv = e * (c - sg / wd * sn)
        g_q = (1.0 - p_qq) / w2
        g_v = -p_vq / w2
        u = load_gain[i] * u_load
        q1[i] = p_qq * q0[i] + p_qv * qd0[i] + g_q * u
        qd1[i] = p_vq * q0[i] + p_vv * qd0[i] + g_v * u
        q_int[i] = (-(p_vq + 2.0 * sg * (p_qq - 1.0)) / w2 * q0[i] - ((p_vv - 1.0) + 2.0 * sg * p_qv) / w2 * qd0[i]
                    + (dt - g_v - 2.0 * sg * g_q) / w2 * u)
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
