"""The loosely coupled GNSS models and the body rate their lever arm needs,
in compiled form: the same equations as ``measurements.GnssPosition.model``,
``GnssVelocity.model`` and ``ModelContext.at`` (which stay the reference),
on the geodetic/ENU view of the state (lat, lon, alt, vel_enu, C_b_n).

At the default scenario's 10 Hz position and velocity fixes the Python
models cost about 12-14 us each and the body rate another 14 us per GNSS
epoch, against about 2 us per compiled call here (``make bench``)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .enu import omega_in, radii
from .linalg import cross, mv3, skew
from .predict import corrected

TWO_PI = 2.0 * math.pi


@njit(cache=True)
def omega_nb_b(lat, alt, v, C, dth, dv, dt, vals, gb, ab, sg, sa):
    """omega_nb_b = corrected omega_ib_b - C_b_n^T (omega_ie_n + omega_en_n)."""
    th, _ = corrected(dth, dv, dt, vals, gb, ab, sg, sa)
    w_ie, w_en = omega_in(lat, alt, v)
    w_in = w_ie + w_en
    out = np.empty(3)
    for i in range(3):
        out[i] = th[i] / dt - (C[0, i] * w_in[0] + C[1, i] * w_in[1] + C[2, i] * w_in[2])
    return out


@njit(cache=True)
def position(lat, lon, alt, v, C, lat_m, lon_m, alt_m, lever_b, dt_meas, n, i_pos, i_att):
    """(residual, H) of an antenna position fix: r + C_b_n l_b + v dt - r_meas
    in ENU metres about the fix (``earth.position_error_enu_m``, longitude
    difference wrapped to [-pi, pi))."""
    r_m, r_n = radii(lat_m)
    d_lon = (lon - lon_m + math.pi) % TWO_PI - math.pi
    if d_lon >= math.pi:
        d_lon = -math.pi
    l_n = mv3(C, lever_b)
    res = np.empty(3)
    res[0] = d_lon * (r_n + alt_m) * math.cos(lat_m) + l_n[0] + v[0] * dt_meas
    res[1] = (lat - lat_m) * (r_m + alt_m) + l_n[1] + v[1] * dt_meas
    res[2] = (alt - alt_m) + l_n[2] + v[2] * dt_meas
    H = np.zeros((3, n))
    for i in range(3):
        H[i, i_pos + i] = 1.0
    H[:, i_att:i_att + 3] = skew(l_n)
    return res, H


@njit(cache=True)
def velocity(v, C, v_meas, omega_nb, lever_b, n, i_vel, i_att, i_bg):
    """(residual, H) of an antenna velocity: v + C_b_n (omega_nb_b x l_b) -
    v_meas; the gyro-bias columns when the state has them (i_bg >= 0)."""
    lever_v_n = mv3(C, cross(omega_nb, lever_b))
    res = v + lever_v_n - v_meas
    H = np.zeros((3, n))
    for i in range(3):
        H[i, i_vel + i] = 1.0
    H[:, i_att:i_att + 3] = skew(lever_v_n)
    if i_bg >= 0:
        L = skew(lever_b)
        for i in range(3):
            for j in range(3):
                H[i, i_bg + j] = C[i, 0] * L[0, j] + C[i, 1] * L[1, j] + C[i, 2] * L[2, j]
    return res, H
