"""Strapdown INS mechanization in the local-level ENU frame with geodetic position.

Velocity, position and attitude updates from IMU increments, with the
two-sample (current + previous interval) coning and sculling corrections
(seed 001 section 3, after Savage; the same algorithm family as KF-GINS),
weighted for unequal intervals (``two_sample_divisor``).
Gravity, Earth rate and transport rate are evaluated at the mid-interval
position and velocity, extrapolated from the previous epoch.
"""
from __future__ import annotations

import numpy as np

from hyper_nav_gnss import earth
from .attitude import cross3, orthonormalize, rotvec_to_C, skew
from .nav_state import ImuSample, NavState


EQUAL_INTERVALS_REL = 1e-9     # intervals this close (relative) count as equal: the stamps' float noise


def two_sample_divisor(dt_s: float, dt_prev_s: float | None) -> float:
    """1 / k, the divisor of the two-sample coning and sculling cross products for
    intervals of unequal length (previous h1 = ``dt_prev_s``, current
    h2 = ``dt_s``): with the rate and specific force linear in time over
    both intervals (w = a + b t, f = c + d t, t = 0 at the interval
    boundary), the coning term 1/2 int_0^h2 alpha x w dt = h2^3 / 12 a x b
    and the sculling term 1/2 int_0^h2 (alpha x f + upsilon x w) dt =
    h2^3 / 12 (a x d + c x b); the increments give
    dth1 x dth2 = a x b h1 h2 (h1 + h2) / 2 and
    dth1 x dv2 + dv1 x dth2 = (a x d + c x b) h1 h2 (h1 + h2) / 2, so both
    terms are k (dth1 x dth2) and k (dth1 x dv2 + dv1 x dth2) with

        k = h2^2 / (6 h1 (h1 + h2))        (= 1/12 for h1 = h2: Savage's two-sample form)

    Returned as the divisor 6 h1 (h1 + h2) / h2^2, exactly 12.0 when the
    intervals are equal to ``EQUAL_INTERVALS_REL`` or there is no previous
    one, so a uniform-rate stream computes ``x / 12.0`` as before, bit for
    bit (recorded bags and regressions replay unchanged). The increments
    must be the integrals over each interval (the importer's
    rate-to-increment conversion: docs/walk_imu.md)."""
    if dt_prev_s is None or dt_prev_s <= 0.0 or abs(dt_prev_s - dt_s) <= EQUAL_INTERVALS_REL * dt_s:
        return 12.0
    return 6.0 * dt_prev_s * (dt_prev_s + dt_s) / (dt_s * dt_s)


def coning_rotation_vector(dtheta_b_rad, dtheta_prev_b_rad, divisor: float = 12.0):
    """Body rotation vector over the interval with the two-sample coning term
    (``divisor``: ``two_sample_divisor``, 12 for equal intervals)."""
    return dtheta_b_rad + cross3(dtheta_prev_b_rad, dtheta_b_rad) / divisor


def sculling_velocity_increment(dtheta_b_rad, dvel_b_mps, dtheta_prev_b_rad, dvel_prev_b_mps,
                                divisor: float = 12.0):
    """Body velocity increment with rotation and two-sample sculling terms
    (``divisor``: ``two_sample_divisor``, 12 for equal intervals)."""
    return (dvel_b_mps + 0.5 * cross3(dtheta_b_rad, dvel_b_mps)
            + (cross3(dtheta_prev_b_rad, dvel_b_mps) + cross3(dvel_prev_b_mps, dtheta_b_rad)) / divisor)


def compensate(imu: ImuSample, state: NavState) -> tuple[np.ndarray, np.ndarray]:
    """Remove the estimated biases (and scale factors) from the increments."""
    return state.compensate(imu.dtheta_b_rad, imu.dvel_b_mps, imu.dt_s)


def propagate(state: NavState, imu: ImuSample, imu_prev: ImuSample | None,
              vel_prev_enu_mps: np.ndarray | None = None) -> NavState:
    """One mechanization step from ``state`` (epoch imu.t_s - dt) to imu.t_s.

    ``imu_prev`` supplies the previous interval for the coning/sculling terms
    (None at the first step). ``vel_prev_enu_mps`` is the velocity one step
    before ``state``, used to extrapolate the mid-interval velocity. Both
    intervals are corrected with the state's current IMU error estimates.
    """
    dth, dv = compensate(imu, state)
    if imu_prev is None:
        dth_p = dv_p = np.zeros(3)
    else:
        dth_p, dv_p = compensate(imu_prev, state)
    v_prev = state.vel_enu_mps if vel_prev_enu_mps is None else vel_prev_enu_mps
    lat1, lon1, alt1, v1, C1 = step(state.lat_rad, state.lon_rad, state.alt_m, state.vel_enu_mps, state.C_b_n,
                                    v_prev, dth, dv, dth_p, dv_p, imu.dt_s,
                                    None if imu_prev is None else imu_prev.dt_s)
    return NavState(t_s=imu.t_s, lat_rad=lat1, lon_rad=lon1, alt_m=alt1, vel_enu_mps=v1, C_b_n=C1,
                    gyro_bias_b_radps=state.gyro_bias_b_radps, accel_bias_b_mps2=state.accel_bias_b_mps2,
                    extra=state.extra)


def step(lat, lon, alt, v0, C_b_n, v_prev, dth, dv, dth_p, dv_p, dt, dt_p=None):
    """The navigation equations over one interval from error-corrected
    increments (dth, dv) and those of the previous interval (dth_p, dv_p;
    zeros at the first step) of length ``dt_p`` (None: equal to dt):
    returns (lat, lon, alt, vel_enu, C_b_n) at the end. Longitude is
    wrapped to [-pi, pi)."""
    d = two_sample_divisor(dt, dt_p)
    # --- velocity: extrapolate position/velocity to mid-interval
    v_mid_ex = 1.5 * v0 - 0.5 * v_prev
    rates = earth.geodetic_rates(lat, alt, v0)
    lat_m, alt_m = lat + 0.5 * dt * rates[0], alt + 0.5 * dt * rates[2]
    w_ie = earth.omega_ie_n(lat_m)
    w_en = earth.omega_en_n(lat_m, alt_m, v_mid_ex)
    zeta = (w_ie + w_en) * dt
    dv_f_b = sculling_velocity_increment(dth, dv, dth_p, dv_p, d)
    dv_f_n = (np.eye(3) - 0.5 * skew(zeta)) @ C_b_n @ dv_f_b
    g_n = earth.gravity_n(lat_m, alt_m)
    dv_g = (g_n - cross3(2.0 * w_ie + w_en, v_mid_ex)) * dt
    v1 = v0 + dv_f_n + dv_g
    # --- position: trapezoidal in geodetic coordinates
    v_mid = 0.5 * (v0 + v1)
    alt1 = alt + v_mid[2] * dt
    alt_mid = 0.5 * (alt + alt1)
    r_m, _ = earth.radii(lat)
    lat1 = lat + v_mid[1] / (r_m + alt_mid) * dt
    lat_mid = 0.5 * (lat + lat1)
    _, r_n = earth.radii(lat_mid)
    lon1 = earth.wrap_lon_rad(lon + v_mid[0] / ((r_n + alt_mid) * np.cos(lat_mid)) * dt)
    # --- attitude: body rotation with coning, nav-frame rotation at mid-interval
    phi_b = coning_rotation_vector(dth, dth_p, d)
    zeta = (earth.omega_ie_n(lat_mid) + earth.omega_en_n(lat_mid, alt_mid, v_mid)) * dt
    C1 = rotvec_to_C(-zeta) @ C_b_n @ rotvec_to_C(phi_b)
    return lat1, lon1, alt1, v1, orthonormalize(C1)
