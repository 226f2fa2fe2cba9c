"""The output predictor's strapdown step in compiled form: one IMU interval
corrected with the filter's IMU error estimates and mechanized, nominal
state only (no covariance) -- ``ErrorStateKF.propagate_nominal`` of the ENU
frame in one call (``core.output_predictor`` runs it at every IMU sample,
ahead of the fusion horizon). The same kernels as the filter's predict
(``predict.imu_terms``, ``enu.mechanize``), so the two agree bit for bit."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .enu import PI, inject, mechanize, radii
from .predict import imu_terms


@njit(cache=True)
def enu_step(x, vals, dth, dv, dt, pdth, pdv, pdt, has_prev, gb, ab, sg, sa, out):
    """Nominal ENU vector after one interval (raw increments of this and the
    previous interval, corrected here) into ``out``."""
    th, v, th_p, v_p, _, _, _ = imu_terms(dth, dv, dt, pdth, pdv, pdt, has_prev, vals, gb, ab, sg, sa)
    mechanize(x, th, v, th_p, v_p, dt, pdt if has_prev else 0.0, out)


@njit(cache=True)
def enu_difference(x_est, x_true):
    """``EnuFrame.difference`` for the small differences the output predictor
    feeds back: phi from the skew part of C_true C_est^T (its rotation vector
    to second order in the angle), the position difference in local ENU
    metres at the true point (``earth.position_error_enu_m``), the velocity
    difference."""
    out = np.empty(9)
    Ce = x_est[6:15].reshape(3, 3)
    Ct = x_true[6:15].reshape(3, 3)
    M = Ct @ Ce.T
    out[0] = 0.5 * (M[2, 1] - M[1, 2])
    out[1] = 0.5 * (M[0, 2] - M[2, 0])
    out[2] = 0.5 * (M[1, 0] - M[0, 1])
    out[3:6] = x_est[3:6] - x_true[3:6]
    lat, alt = x_true[0], x_true[2]
    r_m, r_n = radii(lat)
    d_lon = x_est[1] - x_true[1]
    if not (-PI <= d_lon < PI):
        d_lon = (d_lon + PI) % (2.0 * PI) - PI
    out[6] = d_lon * (r_n + alt) * math.cos(lat)
    out[7] = (x_est[0] - lat) * (r_m + alt)
    out[8] = x_est[2] - alt
    return out


@njit(cache=True)
def enu_feed_back(x, x_then, x_anchor, S, S_then, g_att, g_vel, g_pos):
    """The complementary output predictor's correction in one call
    (``OutputPredictor._feed_back``): c = gains * (difference(x_then,
    x_anchor) - (S - S_then)); returns (x with c taken off, S + c)."""
    dx = enu_difference(x_then, x_anchor)
    c = np.empty(9)
    for i in range(9):
        g = g_att if i < 3 else (g_vel if i < 6 else g_pos)
        c[i] = g * (dx[i] - (S[i] - S_then[i]))
    return inject(x, c), S + c
