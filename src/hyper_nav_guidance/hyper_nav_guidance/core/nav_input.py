"""Navigation messages -> the guidance law's inputs (geodetic position,
ENU velocity), without rclpy: the node hands over the fields.

``nav_msgs/Odometry`` as the fusion node publishes it (``hyper_nav_filter.output``):
pose in the map frame (ENU tangent plane at the map origin), orientation
C_b_map, twist linear velocity in the body frame. So

    r_e   = r0_e + C_n_e(origin) p_map                 (ECEF, then geodetic)
    v_map = C_b_map v_b,   v_enu = C_n_map^T v_map,   C_n_map = C_n_e(origin)^T C_n_e(here)

``hyper_nav_msgs/NavState`` carries (lat, lon, alt, vel_enu) directly.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from hyper_nav_gnss import earth


def odometry_to_geodetic(pos_map_m, q_b_map_xyzw, vel_b_mps, origin_lat_rad, origin_lon_rad, origin_alt_m):
    """(lat_rad, lon_rad, alt_m, vel_enu_mps) of an Odometry in the map frame at the origin."""
    C0 = np.asarray(earth.C_n_e(origin_lat_rad, origin_lon_rad))
    r0 = np.asarray(earth.geodetic_to_ecef(origin_lat_rad, origin_lon_rad, origin_alt_m))
    r = r0 + C0 @ np.asarray(pos_map_m, float)
    lat, lon, alt = (float(x) for x in earth.ecef_to_geodetic(r))
    C_b_map = Rotation.from_quat(np.asarray(q_b_map_xyzw, float)).as_matrix()
    C_n_map = C0.T @ np.asarray(earth.C_n_e(lat, lon))
    v_enu = C_n_map.T @ (C_b_map @ np.asarray(vel_b_mps, float))
    return lat, lon, alt, v_enu


def finite(*xs) -> bool:
    return all(math.isfinite(float(v)) for x in xs for v in np.ravel(x))
