"""Tracker estimate -> output message fields (flat {'a.b': value} dicts), no rclpy.

The tracker publishes the same pair of standard messages a GNSS receiver
does, so every consumer of ``gnss/fix`` + ``gnss/vel`` reads a track:

* ``track/fix`` (sensor_msgs/NavSatFix): the target's geodetic latitude,
  longitude (deg) and altitude (m) with the full ENU position covariance
  (COVARIANCE_TYPE_KNOWN), from the filter's (h, theta, phi) block.
* ``track/vel`` (geometry_msgs/TwistWithCovarianceStamped, ``frame_id``
  ``enu``: the local-level ENU frame at the target, as ``gnss/vel``): the
  velocity w.r.t. the Earth from (v, gamma, psi) with its covariance; the
  angular part is unknown (1e6 variance).

nav_msgs/Odometry would need a body frame and an attitude, which a radar
tracker does not estimate; the rest of the state (gamma, psi, chi, the
input u) goes to ``/diagnostics``.
"""
from __future__ import annotations

import numpy as np

from .conversions import s_to_stamp_fields
from hyper_nav_gnss import earth
from hyper_nav_filter.core.target_tracking.tracker import Estimate


def _header(t_s: float, frame: str) -> dict:
    sec, nsec = s_to_stamp_fields(t_s)
    return {"header.stamp.sec": sec, "header.stamp.nanosec": nsec, "header.frame_id": frame}


def enu_position_covariance(est: Estimate) -> np.ndarray:
    """3x3 ENU covariance of the position from the (h, theta, phi) block."""
    h, lat = est.x[0], est.x[2]
    r_m, r_n = earth.radii(lat)
    # d(E, N, U) / d(h, theta, phi)
    J = np.array([[0.0, (r_n + h) * np.cos(lat), 0.0], [0.0, 0.0, r_m + h], [1.0, 0.0, 0.0]])
    C = J @ est.P[:3, :3] @ J.T
    return 0.5 * (C + C.T)


def enu_velocity(est: Estimate) -> tuple[np.ndarray, np.ndarray]:
    """ENU velocity (m/s) and its 3x3 covariance from (v, gamma, psi)."""
    v, g, p = est.x[3], est.x[4], est.x[5]
    vel = np.array([v * np.cos(g) * np.sin(p), v * np.cos(g) * np.cos(p), v * np.sin(g)])
    J = np.array([[np.cos(g) * np.sin(p), -v * np.sin(g) * np.sin(p), v * np.cos(g) * np.cos(p)],
                  [np.cos(g) * np.cos(p), -v * np.sin(g) * np.cos(p), -v * np.cos(g) * np.sin(p)],
                  [np.sin(g), v * np.cos(g), 0.0]])
    C = J @ est.P[3:6, 3:6] @ J.T
    return vel, 0.5 * (C + C.T)


def track_fix_fields(est: Estimate, frame: str) -> dict:
    out = _header(est.t_s, frame)
    out.update({"status.status": 0, "latitude": float(np.rad2deg(est.x[2])),
                "longitude": float(np.rad2deg(est.x[1])), "altitude": float(est.x[0]),
                "position_covariance": [float(c) for c in enu_position_covariance(est).ravel()],
                "position_covariance_type": 3})       # STATUS_FIX, COVARIANCE_TYPE_KNOWN
    return out


def track_vel_fields(est: Estimate, frame: str) -> dict:
    vel, C = enu_velocity(est)
    cov = np.zeros((6, 6))
    cov[:3, :3] = C
    cov[3:, 3:] = np.eye(3) * 1e6
    out = _header(est.t_s, frame)
    out.update({"twist.twist.linear.x": float(vel[0]), "twist.twist.linear.y": float(vel[1]),
                "twist.twist.linear.z": float(vel[2]), "twist.covariance": [float(c) for c in cov.ravel()]})
    return out
