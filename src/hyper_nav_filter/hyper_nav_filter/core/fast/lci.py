"""LCI frame in compiled form: ``core.lci.mechanization`` (one-plus-previous
coning/sculling/scrolling, all corrections on), ``core.lci.gravity`` (J2 or
WGS-84 normal gravitation) and ``core.frames.lci.LciFrame.error_dynamics``,
on the nominal vector (r_a, v_a, C_b_a row-major)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from hyper_nav_gnss import earth
from ..lci.gravity import A_E_M, GM_M3PS2, J2
from .enu import gravity_up
from .linalg import cross, orthonormalize, rotvec_to_C
from .predict import couple, imu_terms, propagate_covariance

W_IE, E2, A_M = earth.OMEGA_IE_RADPS, earth.E2, earth.A_M


@njit(cache=True)
def gravity_j2(r_geo, w0):
    """``gravity.gravity_j2_a`` (eqs. 7-10) at the geocentric LCI vector."""
    x, y, z = r_geo[0], r_geo[1], r_geo[2]
    r2 = x * x + y * y + z * z
    r = math.sqrt(r2)
    sin_phi = (x * w0[0] + y * w0[1] + z * w0[2]) / r
    k = 1.5 * J2 * A_E_M**2 / r2
    g_r = -GM_M3PS2 / r2 * (1.0 + k * (1.0 - 5.0 * sin_phi * sin_phi)) / r
    g_w = -2.0 * GM_M3PS2 / r2 * k * sin_phi
    return np.array([g_r * x + g_w * w0[0], g_r * y + g_w * w0[1], g_r * z + g_w * w0[2]])


@njit(cache=True)
def gravity_normal(r_geo, t_rel_s, C_t_a):
    """``gravity._gravity_normal_a_scalar``: WGS-84 normal gravity minus the
    centrifugal term, in LCI (t_rel_s: time since the launch epoch)."""
    ang = W_IE * t_rel_s
    ca, sa = math.cos(ang), math.sin(ang)
    rt = C_t_a.T @ r_geo
    x, y, z = ca * rt[0] + sa * rt[1], -sa * rt[0] + ca * rt[1], rt[2]
    a = earth.A_M
    p = math.hypot(x, y)
    lon = math.atan2(y, x)
    lat = math.atan2(z, p * (1.0 - E2))
    for _ in range(6):
        sl = math.sin(lat)
        r_n = a / math.sqrt(1.0 - E2 * sl * sl)
        alt = p / math.cos(lat) - r_n
        lat = math.atan2(z, p * (1.0 - E2 * r_n / (r_n + alt)))
    sl, cl = math.sin(lat), math.cos(lat)
    r_n = a / math.sqrt(1.0 - E2 * sl * sl)
    alt = p / cl - r_n
    g = gravity_up(lat, alt)
    so, co = math.sin(lon), math.cos(lon)
    Gx = -g * cl * co - W_IE * W_IE * x
    Gy = -g * cl * so - W_IE * W_IE * y
    Gz = -g * sl
    return C_t_a @ np.array([ca * Gx - sa * Gy, sa * Gx + ca * Gy, Gz])


@njit(cache=True)
def increments(dth, dv, dth_p, dv_p, T, has_prev):
    """``increments_one_plus_previous`` with every correction on: (phi, dv_sf, dr_sf)."""
    if has_prev:
        a = (dth_p + dth) / (2.0 * T)
        b = (dth - dth_p) / (T * T)
        c = (dv_p + dv) / (2.0 * T)
        d = (dv - dv_p) / (T * T)
    else:
        a, b, c, d = dth / T, np.zeros(3), dv / T, np.zeros(3)
    th = a * T + b * (T * T / 2.0)
    vv = c * T + d * (T * T / 2.0)
    T3 = T**3
    phi = th + cross(a, b) * (T3 / 12.0)
    th_x_dv = cross(th, vv)
    th_x_th_x_dv = cross(th, th_x_dv)
    dv_sf = vv + 0.5 * th_x_dv + th_x_th_x_dv / 6.0
    dv_sf = dv_sf + (cross(a, d) - cross(b, c)) * (T3 / 12.0)
    S_v = c * (T * T / 2.0) + d * (T3 / 6.0)
    S_th = a * (T * T / 2.0) + b * (T3 / 6.0)
    rot = (cross(S_th, vv) + cross(th, S_v)) / 6.0
    exact = (cross(a, c) * (T3 / 6.0) + cross(a, d) * (T3 * T / 12.0)
             + cross(b, c) * (T3 * T / 24.0) + cross(b, d) * (T3 * T * T / 40.0))
    dr_sf = S_v + rot + (exact - rot) + th_x_th_x_dv * (T / 24.0)
    return phi, dv_sf, dr_sf


@njit(cache=True)
def predict(x, t_rel_s, vals, P, dth, dv, dt, pdth, pdv, pdt, has_prev, gb, ab, sg, sa, A, Katt, Kvel, used_att,
            used_vel, Gc, GattM, GvelM, qc, exact, R0_a, w0, C_t_a, normal_gravity, x_out):
    """One LCI predict step: new nominal vector into x_out, returns (P', Phi).
    t_rel_s: time of the state since the launch epoch; R0_a, w0, C_t_a: the
    launch frame; normal_gravity: WGS-84 normal gravity instead of J2."""
    th, v, th_p, v_p, w, f, wdot = imu_terms(dth, dv, dt, pdth, pdv, pdt, has_prev, vals, gb, ab, sg, sa)
    C = x[6:15].copy().reshape(3, 3)
    r, vel = x[0:3], x[3:6]
    F = A.copy()
    f_a = C @ f
    F[3, 1], F[3, 2] = -f_a[2], f_a[1]
    F[4, 0], F[4, 2] = f_a[2], -f_a[0]
    F[5, 0], F[5, 1] = -f_a[1], f_a[0]
    rg = r + R0_a
    rn = math.sqrt(rg[0] ** 2 + rg[1] ** 2 + rg[2] ** 2)
    u = rg / rn
    k = GM_M3PS2 / rn**3
    for i in range(3):
        for j in range(3):
            F[3 + i, 6 + j] = k * (3.0 * u[i] * u[j] - (1.0 if i == j else 0.0))
        F[6 + i, 3 + i] = 1.0
    G = Gc.copy()
    couple(F, G, C, w, f, wdot, Katt, Kvel, used_att, used_vel, GattM, GvelM)
    P1, Phi = propagate_covariance(F, G, qc, P, dt, exact)
    phi, dv_sf, dr_sf = increments(th, v, th_p, v_p, dt, has_prev)
    r_mid = rg + 0.5 * dt * vel
    if normal_gravity:
        g_mid = gravity_normal(r_mid, t_rel_s + 0.5 * dt, C_t_a)
    else:
        g_mid = gravity_j2(r_mid, w0)
    x_out[3:6] = vel + C @ dv_sf + g_mid * dt
    x_out[0:3] = r + vel * dt + C @ dr_sf + g_mid * (0.5 * dt * dt)
    x_out[6:15] = orthonormalize(C @ rotvec_to_C(phi)).ravel()
    return P1, Phi


@njit(cache=True)
def inject(x, dx9):
    """``LciFrame.inject``: C_true = R(phi) C_est, v and r minus their errors."""
    out = np.empty(x.shape[0])
    out[6:15] = (rotvec_to_C(dx9[0:3]) @ x[6:15].copy().reshape(3, 3)).ravel()
    out[3:6] = x[3:6] - dx9[3:6]
    out[0:3] = x[0:3] - dx9[6:9]
    return out


@njit(cache=True)
def geodetic(x, t_rel_s, C_t_a, R0_a_m):
    """The geodetic/ENU view of a nominal vector, as ``LciFrame._geodetic``
    (ECEF through the Earth's rotation since t0, ``earth.ecef_to_geodetic``'s
    eight iterations, ``earth.C_n_e``): (lat, lon, alt, vel_enu, C_b_n, C_n_a).
    In numpy this view cost about 25 us per call (scalar arrays through the
    iteration), run for every solution and every update epoch."""
    ang = W_IE * t_rel_s
    c, sn = math.cos(ang), math.sin(ang)
    Rz = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
    C_e_a = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            C_e_a[i, j] = C_t_a[i, 0] * Rz[0, j] + C_t_a[i, 1] * Rz[1, j] + C_t_a[i, 2] * Rz[2, j]
    ra = x[0:3] + R0_a_m
    r_e = np.empty(3)
    v_e = np.empty(3)
    for i in range(3):
        r_e[i] = C_e_a[0, i] * ra[0] + C_e_a[1, i] * ra[1] + C_e_a[2, i] * ra[2]
        v_e[i] = C_e_a[0, i] * x[3] + C_e_a[1, i] * x[4] + C_e_a[2, i] * x[5]
    v_e[0] -= -W_IE * r_e[1]
    v_e[1] -= W_IE * r_e[0]
    px, py, pz = r_e[0], r_e[1], r_e[2]
    lon = math.atan2(py, px)
    p = math.hypot(px, py)
    lat = math.atan2(pz, p * (1.0 - E2))
    for _ in range(8):
        r_n = A_M / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
        alt = p / math.cos(lat) - r_n
        lat = math.atan2(pz, p * (1.0 - E2 * r_n / (r_n + alt)))
    r_n = A_M / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
    alt = p / math.cos(lat) - r_n
    lon = (lon + math.pi) % (2.0 * math.pi) - math.pi       # earth.wrap_lon_rad
    if lon >= math.pi:
        lon = -math.pi
    sl, cl = math.sin(lat), math.cos(lat)
    so, co = math.sin(lon), math.cos(lon)
    C_n_e = np.array([[-so, -sl * co, cl * co], [co, -sl * so, cl * so], [0.0, cl, sl]])
    C_n_a = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            C_n_a[i, j] = C_e_a[i, 0] * C_n_e[0, j] + C_e_a[i, 1] * C_n_e[1, j] + C_e_a[i, 2] * C_n_e[2, j]
    v_n = np.empty(3)
    C_b_n = np.empty((3, 3))
    for i in range(3):
        v_n[i] = C_n_e[0, i] * v_e[0] + C_n_e[1, i] * v_e[1] + C_n_e[2, i] * v_e[2]
        for j in range(3):
            C_b_n[i, j] = C_n_a[0, i] * x[6 + j] + C_n_a[1, i] * x[9 + j] + C_n_a[2, i] * x[12 + j]
    return lat, lon, alt, v_n, C_b_n, C_n_a
