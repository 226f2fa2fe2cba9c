"""ENU frame in compiled form: the same equations as ``core.mechanization.step``
and ``core.frames.enu.EnuFrame.error_dynamics``, line for line, on the
frame's nominal vector (lat, lon, alt, vel_enu, C_b_n row-major, vel_prev)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from hyper_nav_gnss import earth
from .linalg import mm3, orthonormalize, rotvec_to_C
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


@njit(cache=True, inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    """``linalg.cross`` on scalars (a tuple: no allocation)."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, inline="always")
def _omega_in(lat, alt, v0, v1):
    """``omega_in`` on scalars: (omega_ie_n, omega_en_n) as tuples."""
    r_m, r_n = radii(lat)
    w_ie = (0.0, W_IE * math.cos(lat), W_IE * math.sin(lat))
    w_en = (-v1 / (r_m + alt), v0 / (r_n + alt), v0 * math.tan(lat) / (r_n + alt))
    return w_ie, w_en


@njit(cache=True)
def mechanize(x, dth, dv, dth_p, dv_p, dt, dt_p, out):
    """``mechanization.step`` on the nominal vector; writes ``out``. ``dt_p``:
    the previous interval (<= 0: none), for ``mechanization.two_sample_divisor``
    (the same rule: 12.0 for intervals equal to 1e-9 relative). Vectors as
    scalars (the same operations in the same order as the array form, without
    its ~40 small allocations); the 3 x 3 attitude update as matrices."""
    if dt_p <= 0.0 or abs(dt_p - dt) <= 1e-9 * dt:
        d = 12.0
    else:
        d = 6.0 * dt_p * (dt_p + dt) / (dt * dt)
    lat, lon, alt = x[0], x[1], x[2]
    v0 = (x[3], x[4], x[5])
    vx = (1.5 * x[3] - 0.5 * x[15], 1.5 * x[4] - 0.5 * x[16], 1.5 * x[5] - 0.5 * x[17])
    r_m0, r_n0 = radii(lat)
    lat_m = lat + 0.5 * dt * (v0[1] / (r_m0 + alt))
    alt_m = alt + 0.5 * dt * v0[2]
    w_ie, w_en = _omega_in(lat_m, alt_m, vx[0], vx[1])
    z0, z1, z2 = (w_ie[0] + w_en[0]) * dt, (w_ie[1] + w_en[1]) * dt, (w_ie[2] + w_en[2]) * dt
    c1 = _cross(dth[0], dth[1], dth[2], dv[0], dv[1], dv[2])
    c2 = _cross(dth_p[0], dth_p[1], dth_p[2], dv[0], dv[1], dv[2])
    c3 = _cross(dv_p[0], dv_p[1], dv_p[2], dth[0], dth[1], dth[2])
    fb0 = dv[0] + 0.5 * c1[0] + (c2[0] + c3[0]) / d
    fb1 = dv[1] + 0.5 * c1[1] + (c2[1] + c3[1]) / d
    fb2 = dv[2] + 0.5 * c1[2] + (c2[2] + c3[2]) / d
    dc0 = x[6] * fb0 + x[7] * fb1 + x[8] * fb2
    dc1 = x[9] * fb0 + x[10] * fb1 + x[11] * fb2
    dc2 = x[12] * fb0 + x[13] * fb1 + x[14] * fb2
    zc = _cross(z0, z1, z2, dc0, dc1, dc2)
    g = gravity_up(lat_m, alt_m)
    cor = _cross(2.0 * w_ie[0] + w_en[0], 2.0 * w_ie[1] + w_en[1], 2.0 * w_ie[2] + w_en[2], vx[0], vx[1], vx[2])
    v1_0 = v0[0] + (dc0 - 0.5 * zc[0]) + (0.0 - cor[0]) * dt
    v1_1 = v0[1] + (dc1 - 0.5 * zc[1]) + (0.0 - cor[1]) * dt
    v1_2 = v0[2] + (dc2 - 0.5 * zc[2]) + (-g - cor[2]) * dt
    vm0, vm1, vm2 = 0.5 * (v0[0] + v1_0), 0.5 * (v0[1] + v1_1), 0.5 * (v0[2] + v1_2)
    alt1 = alt + vm2 * dt
    alt_mid = 0.5 * (alt + alt1)
    lat1 = lat + vm1 / (r_m0 + alt_mid) * dt
    lat_mid = 0.5 * (lat + lat1)
    _, r_n = radii(lat_mid)
    lon1 = lon + vm0 / ((r_n + alt_mid) * math.cos(lat_mid)) * dt
    if not (-PI <= lon1 < PI):
        lon1 = (lon1 + PI) % (2.0 * PI) - PI
    cp = _cross(dth_p[0], dth_p[1], dth_p[2], dth[0], dth[1], dth[2])
    phi_b = np.empty(3)
    phi_b[0], phi_b[1], phi_b[2] = dth[0] + cp[0] / d, dth[1] + cp[1] / d, dth[2] + cp[2] / d
    w_ie2, w_en2 = _omega_in(lat_mid, alt_mid, vm0, vm1)
    zeta2 = np.empty(3)
    for a in range(3):
        zeta2[a] = -((w_ie2[a] + w_en2[a]) * dt)
    C = x[6:15].copy().reshape(3, 3)
    C1 = orthonormalize(mm3(mm3(rotvec_to_C(zeta2), C), rotvec_to_C(phi_b)))
    out[0], out[1], out[2] = lat1, lon1, alt1
    out[3], out[4], out[5] = v1_0, v1_1, v1_2
    for i in range(3):
        for j in range(3):
            out[6 + 3 * i + j] = C1[i, j]
    out[15], out[16], out[17] = v0[0], v0[1], v0[2]


@njit(cache=True)
def error_core(x, f_b, F):
    """The att/vel/pos 9 x 9 block of F (``EnuFrame.error_dynamics``) into
    F[:9, :9] (whose entries this does not set must be zero on entry, as in
    ``SystemModel.A``); returns C_b_n. Scalar form of the matrix expressions
    (the same operations; zero terms of the 3 x 3 products left out)."""
    lat, h = x[0], x[2]
    ve, vn, vu = x[3], x[4], x[5]
    C = x[6:15].copy().reshape(3, 3)
    r_m, r_n = radii(lat)
    rmh, rnh = r_m + h, r_n + h
    tl, sl, cl = math.tan(lat), math.sin(lat), math.cos(lat)
    wie1, wie2 = W_IE * cl, W_IE * sl
    wen0, wen1, wen2 = -vn / rmh, ve / rnh, ve * tl / rnh
    fb0, fb1, fb2 = f_b[0], f_b[1], f_b[2]
    fn0 = C[0, 0] * fb0 + C[0, 1] * fb1 + C[0, 2] * fb2
    fn1 = C[1, 0] * fb0 + C[1, 1] * fb1 + C[1, 2] * fb2
    fn2 = C[2, 0] * fb0 + C[2, 1] * fb1 + C[2, 2] * fb2
    # d omega / d r and d omega_en / d v (ENU m, m/s)
    ie11, ie21 = -W_IE * sl / rmh, W_IE * cl / rmh
    ev01, ev10, ev20 = -1.0 / rmh, 1.0 / rnh, tl / rnh
    er02, er12, er21, er22 = vn / rmh**2, -ve / rnh**2, ve / (cl**2 * rnh * rmh), -ve * tl / rnh**2
    # att rows: -[w_in x], d_wen_dv, d_wie_dr + d_wen_dr
    s0, s1, s2 = 0.0 + wen0, wie1 + wen1, wie2 + wen2
    F[0, 1], F[0, 2] = s2, -s1
    F[1, 0], F[1, 2] = -s2, s0
    F[2, 0], F[2, 1] = s1, -s0
    F[0, 4] = ev01
    F[1, 3] = ev10
    F[2, 3] = ev20
    F[0, 8] = er02
    F[1, 7], F[1, 8] = ie11, er12
    F[2, 7], F[2, 8] = ie21 + er21, er22
    # vel rows: [f_n x], -[(2 w_ie + w_en) x] + [v x] d_wen_dv, [v x] (2 d_wie_dr + d_wen_dr)
    F[3, 1], F[3, 2] = -fn2, fn1
    F[4, 0], F[4, 2] = fn2, -fn0
    F[5, 0], F[5, 1] = -fn1, fn0
    t0, t1, t2 = 2.0 * 0.0 + wen0, 2.0 * wie1 + wen1, 2.0 * wie2 + wen2
    # [v x] = [[0, -vu, vn], [vu, 0, -ve], [-vn, ve, 0]]
    F[3, 3] = -vu * ev10 + vn * ev20
    F[3, 4] = t2 + 0.0
    F[3, 5] = -t1 + 0.0
    F[4, 3] = -t2 + (-ve * ev20)
    F[4, 4] = vu * ev01
    F[4, 5] = t0 + 0.0
    F[5, 3] = t1 + ve * ev10
    F[5, 4] = -t0 + (-vn * ev01)
    F[5, 5] = 0.0
    q02, q11, q12, q21, q22 = er02, 2.0 * ie11, er12, 2.0 * ie21 + er21, er22
    F[3, 6] = 0.0
    F[3, 7] = -vu * q11 + vn * q21
    F[3, 8] = -vu * q12 + vn * q22
    F[4, 6] = 0.0
    F[4, 7] = -ve * q21
    F[4, 8] = vu * q02 - ve * q22
    F[5, 6] = 0.0
    F[5, 7] = ve * q11
    F[5, 8] = -vn * q02 + ve * q12
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
