"""The imported streams as message columns for the array writer
(``core/bag_arrays.write_arrays``): the same messages as ``messages.py``
(its per-message generators stay the reference a test compares with), each
field computed for every row at once with the same floating-point
operations, so the bytes are the same (the truth quaternion to 1e-15: a
stack of rotations goes through scipy, one matrix through Shepperd's
method)."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from hyper_nav_workbench.core.bag_arrays import TopicColumns
from hyper_nav_workbench.core.importer.messages import _header, _t

_NS = 1_000_000_000


def stamp_ns(t_s: np.ndarray) -> np.ndarray:
    """int(round(t * 1e9)) of every stamp (``conversions.s_to_stamp_fields``; both round half to even)."""
    return np.round(np.asarray(t_s, float) * 1e9).astype(np.int64)


def _stamps(ns: np.ndarray) -> dict:
    return {"header.stamp.sec": ns // _NS, "header.stamp.nanosec": ns % _NS}


def imu_columns(imu, gyro_var_radps2, accel_var_mps4, frame: str = "imu_link") -> TopicColumns:
    """sensor_msgs/Imu from row 1 on (``messages.imu_messages``)."""
    Imu, Quat, V3 = _t("sensor_msgs/msg/Imu"), _t("geometry_msgs/msg/Quaternion"), _t("geometry_msgs/msg/Vector3")
    ns_all = stamp_ns(imu.t_s)
    ns = ns_all[1:]
    dt = ((ns_all[1:] - ns_all[:-1]) * 1e-9)[:, None]
    w = imu.dtheta_b_rad[1:] / dt
    a = imu.dvel_b_mps[1:] / dt
    gcov = np.diag(np.broadcast_to(gyro_var_radps2, 3)).ravel().astype(float)
    acov = np.diag(np.broadcast_to(accel_var_mps4, 3)).ravel().astype(float)
    ocov = np.zeros(9)
    ocov[0] = -1.0
    proto = Imu(header=_header(0.0, frame), orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0), orientation_covariance=ocov,
                angular_velocity=V3(x=0.0, y=0.0, z=0.0), angular_velocity_covariance=gcov,
                linear_acceleration=V3(x=0.0, y=0.0, z=0.0), linear_acceleration_covariance=acov)
    cols = {**_stamps(ns), "angular_velocity.x": w[:, 0], "angular_velocity.y": w[:, 1], "angular_velocity.z": w[:, 2],
            "linear_acceleration.x": a[:, 0], "linear_acceleration.y": a[:, 1], "linear_acceleration.z": a[:, 2]}
    return TopicColumns("sensor_msgs/msg/Imu", proto, ns, cols)


def fix_columns(fix, frame: str = "gnss_antenna") -> TopicColumns:
    NavSatFix, Status = _t("sensor_msgs/msg/NavSatFix"), _t("sensor_msgs/msg/NavSatStatus")
    ns = stamp_ns(fix.t_s)
    n = len(ns)
    cov = np.zeros((n, 9))
    cov[:, [0, 4, 8]] = fix.pos_sigma_enu_m ** 2
    proto = NavSatFix(header=_header(0.0, frame), status=Status(status=0, service=1), latitude=0.0, longitude=0.0,
                      altitude=0.0, position_covariance=np.zeros(9), position_covariance_type=3)
    cols = {**_stamps(ns), "latitude": np.rad2deg(fix.lat_rad), "longitude": np.rad2deg(fix.lon_rad),
            "altitude": np.asarray(fix.alt_m, float), "position_covariance": cov}
    return TopicColumns("sensor_msgs/msg/NavSatFix", proto, ns, cols)


def vel_columns(fix, frame: str = "enu") -> TopicColumns:
    Msg, Twc, Tw, V3 = (_t("geometry_msgs/msg/TwistWithCovarianceStamped"), _t("geometry_msgs/msg/TwistWithCovariance"),
                        _t("geometry_msgs/msg/Twist"), _t("geometry_msgs/msg/Vector3"))
    ns = stamp_ns(fix.t_s)
    n = len(ns)
    cov = np.zeros((n, 36))
    cov[:, [0, 7, 14]] = fix.vel_sigma_enu_mps ** 2
    z = V3(x=0.0, y=0.0, z=0.0)
    proto = Msg(header=_header(0.0, frame), twist=Twc(twist=Tw(linear=z, angular=z), covariance=np.zeros(36)))
    v = np.asarray(fix.vel_enu_mps, float)
    cols = {**_stamps(ns), "twist.twist.linear.x": v[:, 0], "twist.twist.linear.y": v[:, 1],
            "twist.twist.linear.z": v[:, 2], "twist.covariance": cov}
    return TopicColumns("geometry_msgs/msg/TwistWithCovarianceStamped", proto, ns, cols)


def truth_quat_xyzw(rph_rad: np.ndarray) -> np.ndarray:
    """(x, y, z, w), w >= 0, of body FLU -> ENU from roll, pitch, heading rows
    (``attitude.euler_to_C_b_n`` then ``C_to_quat_xyzw``, for a stack)."""
    r, p, h = np.asarray(rph_rad, float).T
    q = Rotation.from_euler("ZYX", np.column_stack([np.pi / 2 - h, -p, r])).as_quat()
    return np.where(q[:, 3:4] < 0, -q, q)


def truth_columns(truth, enu_frame: str = "enu", body_frame: str = "base_link") -> TopicColumns:
    NavState, Quat = _t("hyper_nav_msgs/msg/NavState"), _t("geometry_msgs/msg/Quaternion")
    fields = NavState.__dataclass_fields__
    ns = stamp_ns(truth.t_s)
    z3 = np.zeros(3)
    values = dict(header=_header(0.0, enu_frame), child_frame_id=body_frame, mode=0, mechanization_frame="TRUTH",
                  lat_rad=0.0, lon_rad=0.0, alt_m=0.0, vel_enu_mps=z3, q_b_enu=Quat(x=0.0, y=0.0, z=0.0, w=1.0),
                  roll_rad=0.0, pitch_rad=0.0, heading_rad=0.0, omega_ib_b_radps=z3, accel_b_mps2=z3,
                  gyro_bias_b_radps=z3, accel_bias_b_mps2=z3, state_blocks=[], state_dim=0, covariance=np.zeros(0),
                  n_updates=0, n_rejected=0, last_nis=-1.0)
    proto = NavState(**{k: v for k, v in values.items() if k in fields})
    q = truth_quat_xyzw(truth.rph_rad)
    rph = np.asarray(truth.rph_rad, float)
    cols = {**_stamps(ns), "lat_rad": truth.lat_rad, "lon_rad": truth.lon_rad, "alt_m": truth.alt_m,
            "vel_enu_mps": np.asarray(truth.vel_enu_mps, float), "q_b_enu.x": q[:, 0], "q_b_enu.y": q[:, 1],
            "q_b_enu.z": q[:, 2], "q_b_enu.w": q[:, 3], "roll_rad": rph[:, 0], "pitch_rad": rph[:, 1],
            "heading_rad": np.mod(rph[:, 2], 2 * np.pi)}
    return TopicColumns("hyper_nav_msgs/msg/NavState", proto, ns, {k: v for k, v in cols.items()
                                                                   if k.split(".")[0] in fields})
