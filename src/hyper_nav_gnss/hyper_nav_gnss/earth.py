"""WGS-84 Earth model for local-level (ENU) navigation.

Pure functions of geodetic position, SI units, angles in radians.
Notation: n = local-level ENU frame, e = ECEF, i = inertial; ``omega_ie_n``
is the Earth rate expressed in n, ``omega_en_n`` the transport rate.
"""
from __future__ import annotations

import math

import numpy as np

A_M = 6378137.0                    # WGS-84 semi-major axis
F = 1.0 / 298.257223563            # flattening
E2 = F * (2.0 - F)                 # first eccentricity squared
OMEGA_IE_RADPS = 7.2921151467e-5   # Earth rotation rate
GM_M3PS2 = 3.986004418e14
# Normal gravity (Somigliana) constants, WGS-84.
G_EQUATOR_MPS2 = 9.7803253359
K_SOMIGLIANA = 0.00193185265241
M_RATIO = OMEGA_IE_RADPS**2 * A_M**2 * (1 - F) * A_M / GM_M3PS2  # m = w^2 a^2 b / GM
G0_MPS2 = 9.80665                  # standard gravity, for datasheet units (g, mg)


def _vec3(x, y, z):
    """Stack three components along a last axis; a plain array for scalars
    (np.stack costs ~15 us per call on scalars, np.array ~1 us)."""
    if (isinstance(x, float) and isinstance(y, float) and isinstance(z, float)) or \
            (np.ndim(x) == 0 and np.ndim(y) == 0 and np.ndim(z) == 0):       # (floats first: np.ndim costs ~0.3 us)
        return np.array([x, y, z], dtype=float)
    x, y, z = np.broadcast_arrays(x, y, z)
    return np.stack([x, y, z], axis=-1)


def wrap_lon_rad(lon_rad):
    """Longitude (or a longitude difference) wrapped to [-pi, pi) [rad].

    Every boundary that emits a longitude (truth, messages, filter state,
    report) and every longitude difference goes through this function, so a
    flight across 180 deg sees -180 on the far side and differences of a few
    metres, not 2 pi. Scalars stay Python floats (the per-epoch hot path:
    ~0.2 us against ~2 us for numpy on a scalar); arrays are vectorised."""
    if isinstance(lon_rad, float):
        w = (lon_rad + math.pi) % (2.0 * math.pi) - math.pi
        return -math.pi if w >= math.pi else w       # (x + pi) % 2pi can round up to 2pi
    w = np.mod(np.asarray(lon_rad, dtype=float) + np.pi, 2.0 * np.pi) - np.pi
    return np.where(w >= np.pi, -np.pi, w) if np.ndim(w) else float(-np.pi if w >= np.pi else w)


def radii(lat_rad):
    """Meridian (R_M) and prime-vertical (R_N) radii of curvature [m]."""
    s2 = np.sin(lat_rad) ** 2
    w = np.sqrt(1.0 - E2 * s2)
    r_n = A_M / w
    r_m = A_M * (1.0 - E2) / w**3
    return r_m, r_n


def gravity_n(lat_rad, alt_m):
    """Normal gravity vector in ENU [m/s^2] (WGS-84 Somigliana with the
    second-order free-air height correction); it points down: (0, 0, -g)."""
    s2 = np.sin(lat_rad) ** 2
    g_0 = G_EQUATOR_MPS2 * (1.0 + K_SOMIGLIANA * s2) / np.sqrt(1.0 - E2 * s2)
    g_h = g_0 * (1.0 - 2.0 / A_M * (1.0 + F + M_RATIO - 2.0 * F * s2) * alt_m
                 + 3.0 / A_M**2 * alt_m**2)
    return _vec3(0.0 * g_h, 0.0 * g_h, -g_h)


def omega_ie_n(lat_rad):
    """Earth rotation rate in ENU [rad/s]."""
    return _vec3(0.0 * lat_rad, OMEGA_IE_RADPS * np.cos(lat_rad), OMEGA_IE_RADPS * np.sin(lat_rad))


def omega_en_n(lat_rad, alt_m, vel_enu_mps):
    """Transport rate (rotation of ENU w.r.t. ECEF) in ENU [rad/s]."""
    r_m, r_n = radii(lat_rad)
    v_e, v_n = vel_enu_mps[..., 0], vel_enu_mps[..., 1]
    return _vec3(-v_n / (r_m + alt_m), v_e / (r_n + alt_m), v_e * np.tan(lat_rad) / (r_n + alt_m))


def geodetic_rates(lat_rad, alt_m, vel_enu_mps):
    """Time derivatives (lat_dot, lon_dot, alt_dot) of geodetic position."""
    r_m, r_n = radii(lat_rad)
    return _vec3(vel_enu_mps[..., 1] / (r_m + alt_m),
                 vel_enu_mps[..., 0] / ((r_n + alt_m) * np.cos(lat_rad)),
                 vel_enu_mps[..., 2])


def geodetic_to_ecef(lat_rad, lon_rad, alt_m):
    """Geodetic (WGS-84) to ECEF position [m]; vectorised over inputs."""
    _, r_n = radii(lat_rad)
    cl, sl = np.cos(lat_rad), np.sin(lat_rad)
    return _vec3((r_n + alt_m) * cl * np.cos(lon_rad),
                 (r_n + alt_m) * cl * np.sin(lon_rad),
                 (r_n * (1.0 - E2) + alt_m) * sl)


def ecef_to_geodetic(r_e_m):
    """ECEF position [m] to geodetic (lat_rad, lon_rad, alt_m), by iteration
    converging to < 1e-9 m for altitudes from the ground to orbit."""
    r_e_m = np.asarray(r_e_m, dtype=float)
    x, y, z = r_e_m[..., 0], r_e_m[..., 1], r_e_m[..., 2]
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1.0 - E2))
    alt = np.zeros_like(p)
    for _ in range(8):
        _, r_n = radii(lat)
        alt = p / np.cos(lat) - r_n
        lat = np.arctan2(z, p * (1.0 - E2 * r_n / (r_n + alt)))
    _, r_n = radii(lat)
    alt = p / np.cos(lat) - r_n
    return lat, wrap_lon_rad(lon), alt


def C_n_e(lat_rad, lon_rad):
    """Rotation ENU -> ECEF (columns are the E, N, U axes in ECEF)."""
    sl, cl = np.sin(lat_rad), np.cos(lat_rad)
    so, co = np.sin(lon_rad), np.cos(lon_rad)
    return np.array([[-so, -sl * co, cl * co],
                     [co, -sl * so, cl * so],
                     [0.0, cl, sl]])


def enu_offset_m(lat0_rad, lon0_rad, alt0_m, lat_rad, lon_rad, alt_m):
    """ENU coordinates [m] of a geodetic point in the tangent plane at point 0."""
    d_e = geodetic_to_ecef(lat_rad, lon_rad, alt_m) - geodetic_to_ecef(lat0_rad, lon0_rad, alt0_m)
    return d_e @ C_n_e(lat0_rad, lon0_rad)


def position_error_enu_m(lat_rad, lon_rad, alt_m, lat_ref_rad, lon_ref_rad, alt_ref_m):
    """Small position difference (estimate - reference) in local ENU metres;
    the longitude difference is wrapped to [-pi, pi) (a pair of points either
    side of 180 deg is metres apart, not an Earth circumference)."""
    r_m, r_n = radii(lat_ref_rad)
    if isinstance(lon_rad, float) and isinstance(lon_ref_rad, float):    # one point: the per-update hot path
        d_lon = wrap_lon_rad(float(lon_rad - lon_ref_rad))
    else:
        d_lon = wrap_lon_rad(np.asarray(lon_rad, dtype=float) - lon_ref_rad)
    return _vec3(d_lon * (r_n + alt_ref_m) * np.cos(lat_ref_rad),
                 (lat_rad - lat_ref_rad) * (r_m + alt_ref_m),
                 alt_m - alt_ref_m)


def elevation_azimuth(r_rx_e_m, r_sat_e_m, geodetic=None):
    """Elevation and azimuth [rad] of ECEF points r_sat (N,3) seen from r_rx (3,),
    in the receiver's geodetic ENU frame (azimuth from north, east positive).
    ``geodetic``: (lat, lon, alt) of r_rx when the caller has it already."""
    lat, lon, _ = ecef_to_geodetic(np.asarray(r_rx_e_m, float)) if geodetic is None else geodetic
    d_enu = (np.atleast_2d(r_sat_e_m) - r_rx_e_m) @ C_n_e(lat, lon)
    el = np.arctan2(d_enu[:, 2], np.hypot(d_enu[:, 0], d_enu[:, 1]))
    az = np.mod(np.arctan2(d_enu[:, 0], d_enu[:, 1]), 2 * np.pi)
    return el, az
