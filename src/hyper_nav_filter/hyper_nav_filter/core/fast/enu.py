"""ENU frame in compiled form: the same equations as ``core.mechanization.step``
and ``core.frames.enu.EnuFrame.error_dynamics``, line for line, on the
frame's nominal vector (lat, lon, alt, vel_enu, C_b_n row-major, vel_prev)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .. import earth
from .linalg import cross, mm3, mv3, orthonormalize, rotvec_to_C, skew
from .predict import couple, imu_terms, propagate_covariance

A_M, E2, F_WGS, W_IE = earth.A_M, earth.E2, earth.F, earth.OMEGA_IE_RADPS
G_EQ, K_SOM, M_RATIO = earth.G_EQUATOR_MPS2, earth.K_SOMIGLIANA, earth.M_RATIO
PI = math.pi


@njit(cache=True, inline="always")
def radii(lat):
    s2 = math.sin(lat) ** 2
    w = math.sqrt(1.0 - E2 * s2)
    return A_M * (1.0 - E2) / w**3, A_M / w


@njit(cache=True, inline="always")
def gravity_up(lat, alt):
    """Magnitude of the normal gravity (``earth.gravity_n`` = (0, 0, -g))."""
    s2 = math.sin(lat) ** 2
    g_0 = G_EQ * (1.0 + K_SOM * s2) / math.sqrt(1.0 - E2 * s2)
    return g_0 * (1.0 - 2.0 / A_M * (1.0 + F_WGS + M_RATIO - 2.0 * F_WGS * s2) * alt + 3.0 / A_M**2 * alt**2)


@njit(cache=True, inline="always")
def omega_in(lat, alt, v):
    """omega_ie_n + omega_en_n and each of them."""
    r_m, r_n = radii(lat)
    w_ie = np.array([0.0, W_IE * math.cos(lat), W_IE * math.sin(lat)])
    w_en = np.array([-v[1] / (r_m + alt), v[0] / (r_n + alt), v[0] * math.tan(lat) / (r_n + alt)])
    return w_ie, w_en


@njit(cache=True)
def mechanize(x, dth, dv, dth_p, dv_p, dt, dt_p, out):
    """``mechanization.step`` on the nominal vector; writes ``out``. ``dt_p``:
    the previous interval (<= 0: none), for ``mechanization.two_sample_divisor``
    (the same rule: 12.0 for intervals equal to 1e-9 relative)."""
    if dt_p <= 0.0 or abs(dt_p - dt) <= 1e-9 * dt:
        d = 12.0
    else:
        d = 6.0 * dt_p * (dt_p + dt) / (dt * dt)
    lat, lon, alt = x[0], x[1], x[2]
    v0 = x[3:6].copy()
    C = x[6:15].copy().reshape(3, 3)
    v_prev = x[15:18]
    v_mid_ex = 1.5 * v0 - 0.5 * v_prev
    r_m0, r_n0 = radii(lat)
    lat_m = lat + 0.5 * dt * (v0[1] / (r_m0 + alt))
    alt_m = alt + 0.5 * dt * v0[2]
    w_ie, w_en = omega_in(lat_m, alt_m, v_mid_ex)
    zeta = (w_ie + w_en) * dt
    dv_f_b = dv + 0.5 * cross(dth, dv) + (cross(dth_p, dv) + cross(dv_p, dth)) / d
    dv_c = mv3(C, dv_f_b)
    dv_f_n = dv_c - 0.5 * cross(zeta, dv_c)          # (I - [zeta x] / 2) C dv
    g = gravity_up(lat_m, alt_m)
    dv_g = (np.array([0.0, 0.0, -g]) - cross(2.0 * w_ie + w_en, v_mid_ex)) * dt
    v1 = v0 + dv_f_n + dv_g
    v_mid = 0.5 * (v0 + v1)
    alt1 = alt + v_mid[2] * dt
    alt_mid = 0.5 * (alt + alt1)
    lat1 = lat + v_mid[1] / (r_m0 + alt_mid) * dt
    lat_mid = 0.5 * (lat + lat1)
    _, r_n = radii(lat_mid)
    lon1 = lon + v_mid[0] / ((r_n + alt_mid) * math.cos(lat_mid)) * dt
    if not (-PI <= lon1 < PI):
        lon1 = (lon1 + PI) % (2.0 * PI) - PI
    phi_b = dth + cross(dth_p, dth) / d
    w_ie2, w_en2 = omega_in(lat_mid, alt_mid, v_mid)
    zeta2 = (w_ie2 + w_en2) * dt
    C1 = orthonormalize(mm3(mm3(rotvec_to_C(-zeta2), C), rotvec_to_C(phi_b)))
    out[0], out[1], out[2] = lat1, lon1, alt1
    out[3:6] = v1
    out[6:15] = C1.ravel()
    out[15:18] = v0


@njit(cache=True)
def error_core(x, f_b, F):
    """The att/vel/pos 9 x 9 block of F (``EnuFrame.error_dynamics``) into
    F[:9, :9]; returns C_b_n."""
    lat, h = x[0], x[2]
    v = x[3:6]
    ve, vn, vu = v[0], v[1], v[2]
    C = x[6:15].copy().reshape(3, 3)
    r_m, r_n = radii(lat)
    rmh, rnh = r_m + h, r_n + h
    tl, sl, cl = math.tan(lat), math.sin(lat), math.cos(lat)
    w_ie = np.array([0.0, W_IE * cl, W_IE * sl])
    w_en = np.array([-vn / rmh, ve / rnh, ve * tl / rnh])
    f_n = mv3(C, f_b)
    d_wie_dr = np.zeros((3, 3))
    d_wie_dr[1, 1] = -W_IE * sl / rmh
    d_wie_dr[2, 1] = W_IE * cl / rmh
    d_wen_dv = np.zeros((3, 3))
    d_wen_dv[0, 1] = -1.0 / rmh
    d_wen_dv[1, 0] = 1.0 / rnh
    d_wen_dv[2, 0] = tl / rnh
    d_wen_dr = np.zeros((3, 3))
    d_wen_dr[0, 2] = vn / rmh**2
    d_wen_dr[1, 2] = -ve / rnh**2
    d_wen_dr[2, 1] = ve / (cl**2 * rnh * rmh)
    d_wen_dr[2, 2] = -ve * tl / rnh**2
    sv = skew(v)
    F[0:3, 0:3] = -skew(w_ie + w_en)
    F[0:3, 3:6] = d_wen_dv
    F[0:3, 6:9] = d_wie_dr + d_wen_dr
    F[3:6, 0:3] = skew(f_n)
    F[3:6, 3:6] = -skew(2.0 * w_ie + w_en) + mm3(sv, d_wen_dv)
    F[3:6, 6:9] = mm3(sv, 2.0 * d_wie_dr + d_wen_dr)
    g = gravity_up(lat, h)
    F[5, 8] += 2.0 * g / math.sqrt(r_m * r_n)
    for i in range(3):
        F[6 + i, 3 + i] = 1.0
    F[6, 6] = vu / rnh - vn * tl / rmh
    F[6, 7] = ve * tl / rmh
    F[6, 8] = -ve / rnh
    F[7, 7] = vu / rmh
    F[7, 8] = -vn / rmh
    return C


@njit(cache=True)
def predict(x, vals, P, dth, dv, dt, pdth, pdv, pdt, has_prev, gb, ab, sg, sa, A, Katt, Kvel, used_att, used_vel,
            Gc, GattM, GvelM, qc, exact, x_out):
    """One ENU predict step (``ErrorStateKF.predict`` without IMU
    pre-processing blocks): writes the new nominal vector into x_out and
    returns (P', Phi). (dth, dv, dt), (pdth, pdv, pdt): raw increments of
    this and the previous interval."""
    th, v, th_p, v_p, w, f, wdot = imu_terms(dth, dv, dt, pdth, pdv, pdt, has_prev, vals, gb, ab, sg, sa)
    F = A.copy()
    C = error_core(x, f, F)
    G = Gc.copy()
    couple(F, G, C, w, f, wdot, Katt, Kvel, used_att, used_vel, GattM, GvelM)
    P1, Phi = propagate_covariance(F, G, qc, P, dt, exact)
    mechanize(x, th, v, th_p, v_p, dt, pdt if has_prev else 0.0, x_out)
    return P1, Phi


@njit(cache=True)
def inject(x, dx9):
    """``EnuFrame.inject``: nominal minus the att/vel/pos error estimate,
    C_true = R(phi) C_est, position error in local ENU metres."""
    out = x.copy()
    C = mm3(rotvec_to_C(dx9[0:3]), x[6:15].copy().reshape(3, 3))
    out[6:15] = C.ravel()
    out[3:6] = x[3:6] - dx9[3:6]
    lat, alt = x[0], x[2]
    r_m, r_n = radii(lat)
    lat1 = lat - dx9[7] / (r_m + alt)
    out[0] = lat1
    lon1 = x[1] - dx9[6] / ((r_n + alt) * math.cos(lat1))
    lon1 = (lon1 + PI) % (2.0 * PI) - PI            # earth.wrap_lon_rad
    out[1] = -PI if lon1 >= PI else lon1
    out[2] = alt - dx9[8]
    return out
