"""Solution -> output message fields (flat {'a.b': value} dicts), no rclpy.
Covariances are flat numpy arrays (``ros_util.assign_fields`` fills the
message's own storage from their bytes).

Frames (README, "Frames"): ``nav/state`` is geodetic + local-level ENU at the
current position (frame ``enu``); ``nav/odom`` is in ``map``, the ENU tangent
plane at the scenario origin (REP-105), child ``base_link`` (FLU); its twist
is in the child frame, as nav_msgs/Odometry defines (angular: the body rate
relative to the Earth-fixed map, omega_eb_b); ``nav/fix`` is a NavSatFix with
the ENU position covariance.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .conversions import s_to_stamp_fields
from hyper_nav_gnss import earth
from .core.attitude import C_b_n_to_euler, C_to_quat_xyzw
from .core.fusion import Solution
from .core.state_layout import StateLayout


@dataclass(frozen=True)
class OutputFrames:
    map: str
    enu: str
    body: str
    origin_lat_rad: float
    origin_lon_rad: float
    origin_alt_m: float


def _header(t_s: float, frame: str) -> dict:
    sec, nsec = s_to_stamp_fields(t_s)
    return {"header.stamp.sec": sec, "header.stamp.nanosec": nsec, "header.frame_id": frame}


def navstate_fields(sol: Solution, layout: StateLayout, frames: OutputFrames, mechanization_frame: str = "ENU") -> dict:
    s = sol.state
    roll, pitch, heading = C_b_n_to_euler(s.C_b_n)
    q = C_to_quat_xyzw(s.C_b_n)
    d = _header(sol.t_s, frames.enu)
    d.update({
        "child_frame_id": frames.body, "mode": sol.mode, "mechanization_frame": mechanization_frame,
        "lat_rad": float(s.lat_rad), "lon_rad": float(s.lon_rad), "alt_m": float(s.alt_m),
        "vel_enu_mps": s.vel_enu_mps.tolist(),
        "q_b_enu.x": q[0], "q_b_enu.y": q[1], "q_b_enu.z": q[2], "q_b_enu.w": q[3],
        "roll_rad": float(roll), "pitch_rad": float(pitch), "heading_rad": float(heading),
        "omega_ib_b_radps": sol.omega_ib_b_radps.tolist(), "accel_b_mps2": sol.f_b_mps2.tolist(),
        "gyro_bias_b_radps": s.gyro_bias_b_radps.tolist(), "accel_bias_b_mps2": s.accel_bias_b_mps2.tolist(),
        "state_blocks": layout.describe(), "state_dim": layout.dim, "covariance": sol.P.ravel(),
        "n_updates": sol.n_updates, "n_rejected": sol.n_rejected,
        "last_nis": float(sol.last_nis) if np.isfinite(sol.last_nis) else -1.0,
    })
    return d


@functools.lru_cache(maxsize=8)
def _origin(lat_rad: float, lon_rad: float, alt_m: float):
    """ECEF position and C_n_e of a map origin (computed once per origin)."""
    return earth.geodetic_to_ecef(lat_rad, lon_rad, alt_m), earth.C_n_e(lat_rad, lon_rad)


def map_pose(sol: Solution, frames: OutputFrames):
    """Position [m] and attitude C_b_map in the map frame (ENU tangent plane at origin):
    ``earth.enu_offset_m`` from the origin, C_n_map = C_n_e(origin)^T C_n_e(here)."""
    s = sol.state
    r0_e, C0_n_e = _origin(frames.origin_lat_rad, frames.origin_lon_rad, frames.origin_alt_m)
    pos = (earth.geodetic_to_ecef(s.lat_rad, s.lon_rad, s.alt_m) - r0_e) @ C0_n_e
    C_n_map = C0_n_e.T @ earth.C_n_e(s.lat_rad, s.lon_rad)
    return pos, C_n_map, C_n_map @ s.C_b_n


def odometry_fields(sol: Solution, layout: StateLayout, frames: OutputFrames, pose=None) -> dict:
    """nav_msgs/Odometry fields; ``pose``: ``map_pose`` of the solution when already computed."""
    s = sol.state
    pos, C_n_map, C_b_map = map_pose(sol, frames) if pose is None else pose
    q = C_to_quat_xyzw(C_b_map)
    P = sol.P
    cov = np.zeros((6, 6))
    p_sl, a_sl, v_sl = layout.sl("pos"), layout.sl("att"), layout.sl("vel")
    cov[:3, :3] = C_n_map @ P[p_sl, p_sl] @ C_n_map.T
    cov[3:, 3:] = C_n_map @ P[a_sl, a_sl] @ C_n_map.T   # rotation about map axes
    cov[:3, 3:] = C_n_map @ P[p_sl, a_sl] @ C_n_map.T
    cov[3:, :3] = cov[:3, 3:].T
    v_b = s.C_b_n.T @ s.vel_enu_mps
    # map is Earth-fixed: the body's angular velocity relative to it is omega_eb = omega_ib - omega_ie
    w_eb_b = sol.omega_ib_b_radps - s.C_b_n.T @ earth.omega_ie_n(s.lat_rad)
    tcov = np.zeros((6, 6))
    tcov[:3, :3] = s.C_b_n.T @ P[v_sl, v_sl] @ s.C_b_n
    if layout.has("bg"):
        bg = layout.sl("bg")
        tcov[3:, 3:] = P[bg, bg]
    else:
        tcov[3:, 3:] = np.eye(3) * 1e-8
    d = _header(sol.t_s, frames.map)
    d.update({
        "child_frame_id": frames.body,
        "pose.pose.position.x": float(pos[0]), "pose.pose.position.y": float(pos[1]),
        "pose.pose.position.z": float(pos[2]),
        "pose.pose.orientation.x": q[0], "pose.pose.orientation.y": q[1],
        "pose.pose.orientation.z": q[2], "pose.pose.orientation.w": q[3],
        "pose.covariance": cov.ravel(),
        "twist.twist.linear.x": float(v_b[0]), "twist.twist.linear.y": float(v_b[1]),
        "twist.twist.linear.z": float(v_b[2]),
        "twist.twist.angular.x": float(w_eb_b[0]),
        "twist.twist.angular.y": float(w_eb_b[1]),
        "twist.twist.angular.z": float(w_eb_b[2]),
        "twist.covariance": tcov.ravel(),
    })
    return d


def navsatfix_fields(sol: Solution, layout: StateLayout, frames: OutputFrames) -> dict:
    s = sol.state
    p_sl = layout.sl("pos")
    d = _header(sol.t_s, frames.body)
    d.update({
        "status.status": 0, "status.service": 1,   # STATUS_FIX, SERVICE_GPS
        "latitude": float(np.rad2deg(s.lat_rad)), "longitude": float(np.rad2deg(s.lon_rad)),
        "altitude": float(s.alt_m),
        "position_covariance": sol.P[p_sl, p_sl].ravel(),
        "position_covariance_type": 3,                   # COVARIANCE_TYPE_KNOWN
    })
    return d


def transform_fields(sol: Solution, frames: OutputFrames, pose=None) -> dict:
    """geometry_msgs/TransformStamped of ``map -> base_link`` (REP-105) at the
    solution epoch: the same pose as ``nav/odom`` (``pose``: its ``map_pose``
    when already computed)."""
    pos, _, C_b_map = map_pose(sol, frames) if pose is None else pose
    q = C_to_quat_xyzw(C_b_map)
    d = _header(sol.t_s, frames.map)
    d.update({"child_frame_id": frames.body,
              "transform.translation.x": float(pos[0]), "transform.translation.y": float(pos[1]),
              "transform.translation.z": float(pos[2]),
              "transform.rotation.x": float(q[0]), "transform.rotation.y": float(q[1]),
              "transform.rotation.z": float(q[2]), "transform.rotation.w": float(q[3])})
    return d


def static_transform_fields(t_s: float, parent: str, child: str, position_m,
                            rotation_xyzw=(0.0, 0.0, 0.0, 1.0)) -> dict:
    """A sensor frame fixed in the body: translation = its lever arm (parent
    axes, m); rotation = the child's axes in the parent's (unit quaternion
    x, y, z, w: v_parent = R v_child), parallel by default."""
    d = _header(t_s, parent)
    qx, qy, qz, qw = (float(v) for v in rotation_xyzw)
    d.update({"child_frame_id": child,
              "transform.translation.x": float(position_m[0]), "transform.translation.y": float(position_m[1]),
              "transform.translation.z": float(position_m[2]),
              "transform.rotation.x": qx, "transform.rotation.y": qy, "transform.rotation.z": qz,
              "transform.rotation.w": qw})
    return d
