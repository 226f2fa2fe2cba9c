"""Imported arrays -> standard ROS 2 messages in a rosbag2/MCAP bag (rosbags,
no rclpy), on the topics of the default fusion sources:

  imu/data_raw  sensor_msgs/Imu      mean rates over (previous stamp, stamp] (README "IMU message")
  gnss/fix      sensor_msgs/NavSatFix  ENU position covariance (REP-145)
  gnss/vel      geometry_msgs/TwistWithCovarianceStamped (frame enu), when the file has velocities
  truth/state   hyper_nav_msgs/NavState (mode TRUTH), when a truth file is given

Log time = header stamp (ns), so the bag replays in data time.
"""
from __future__ import annotations

import numpy as np

from hyper_nav_filter.conversions import s_to_stamp_fields
from hyper_nav_filter.core.attitude import C_to_quat_xyzw, euler_to_C_b_n

from hyper_nav_workbench.core.bag import BagWriter, serialize, typestore


def _t(name):
    return typestore().types[name]


def _header(t_s: float, frame: str):
    sec, nsec = s_to_stamp_fields(t_s)
    return _t("std_msgs/msg/Header")(stamp=_t("builtin_interfaces/msg/Time")(sec=sec, nanosec=nsec), frame_id=frame)


def _v3(v):
    return _t("geometry_msgs/msg/Vector3")(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def _stamp_ns(t_s: float) -> int:
    sec, nsec = s_to_stamp_fields(t_s)
    return sec * 1_000_000_000 + nsec


def imu_messages(imu, gyro_var_radps2: np.ndarray, accel_var_mps4: np.ndarray, frame: str = "imu_link"):
    """(t_ns, Imu) from row 1 on: the first row only starts the time line.
    The rates divide each increment by the stamp difference exactly as the
    fusion core multiplies them back."""
    Imu, Quat = _t("sensor_msgs/msg/Imu"), _t("geometry_msgs/msg/Quaternion")
    ns = np.array([_stamp_ns(t) for t in imu.t_s])
    gcov = np.diag(np.broadcast_to(gyro_var_radps2, 3)).ravel().astype(float)
    acov = np.diag(np.broadcast_to(accel_var_mps4, 3)).ravel().astype(float)
    ocov = np.zeros(9)
    ocov[0] = -1.0
    for k in range(1, len(ns)):
        dt = (ns[k] - ns[k - 1]) * 1e-9
        yield ns[k], Imu(header=_header(imu.t_s[k], frame), orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0),
                         orientation_covariance=ocov, angular_velocity=_v3(imu.dtheta_b_rad[k] / dt),
                         angular_velocity_covariance=gcov, linear_acceleration=_v3(imu.dvel_b_mps[k] / dt),
                         linear_acceleration_covariance=acov)


def fix_messages(fix, frame: str = "gnss_antenna"):
    NavSatFix, Status = _t("sensor_msgs/msg/NavSatFix"), _t("sensor_msgs/msg/NavSatStatus")
    for k in range(len(fix.t_s)):
        cov = np.diag(fix.pos_sigma_enu_m[k] ** 2).ravel().astype(float)
        yield _stamp_ns(fix.t_s[k]), NavSatFix(
            header=_header(fix.t_s[k], frame), status=Status(status=0, service=1),
            latitude=float(np.rad2deg(fix.lat_rad[k])), longitude=float(np.rad2deg(fix.lon_rad[k])),
            altitude=float(fix.alt_m[k]), position_covariance=cov, position_covariance_type=3)


def vel_messages(fix, frame: str = "enu"):
    Msg, Twc, Tw = (_t("geometry_msgs/msg/TwistWithCovarianceStamped"), _t("geometry_msgs/msg/TwistWithCovariance"),
                    _t("geometry_msgs/msg/Twist"))
    for k in range(len(fix.t_s)):
        cov = np.zeros((6, 6))
        cov[:3, :3] = np.diag(fix.vel_sigma_enu_mps[k] ** 2)
        yield _stamp_ns(fix.t_s[k]), Msg(header=_header(fix.t_s[k], frame), twist=Twc(
            twist=Tw(linear=_v3(fix.vel_enu_mps[k]), angular=_v3(np.zeros(3))), covariance=cov.ravel()))


def truth_messages(truth, enu_frame: str = "enu", body_frame: str = "base_link"):
    NavState, Quat = _t("hyper_nav_msgs/msg/NavState"), _t("geometry_msgs/msg/Quaternion")
    fields = NavState.__dataclass_fields__
    z3 = np.zeros(3)
    for k in range(len(truth.t_s)):
        r, p, h = truth.rph_rad[k]
        q = C_to_quat_xyzw(euler_to_C_b_n(r, p, h))
        values = dict(header=_header(truth.t_s[k], enu_frame), child_frame_id=body_frame, mode=0,
                      mechanization_frame="TRUTH", lat_rad=float(truth.lat_rad[k]), lon_rad=float(truth.lon_rad[k]),
                      alt_m=float(truth.alt_m[k]), vel_enu_mps=np.asarray(truth.vel_enu_mps[k], float),
                      q_b_enu=Quat(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])),
                      roll_rad=float(r), pitch_rad=float(p), heading_rad=float(np.mod(h, 2 * np.pi)),
                      omega_ib_b_radps=z3, accel_b_mps2=z3, gyro_bias_b_radps=z3, accel_bias_b_mps2=z3,
                      state_blocks=[], state_dim=0, covariance=np.zeros(0), n_updates=0, n_rejected=0, last_nis=-1.0)
        yield _stamp_ns(truth.t_s[k]), NavState(**{k2: v for k2, v in values.items() if k2 in fields})


def write_bag(path, streams: dict, qos: dict | None = None) -> dict:
    """Write {topic: (msgtype, iterable of (t_ns, msg))} in time order; returns counts per topic.
    ``qos``: {topic: [offered QoS profile]} (``bag.qos_profile``), e.g. transient
    local for ``/gnss/ephemeris`` so the player offers it latched."""
    import heapq
    def tagged(i, topic, msgtype, gen):
        for t_ns, msg in gen:
            yield t_ns, i, topic, msgtype, msg
    iters = [tagged(i, topic, msgtype, gen) for i, (topic, (msgtype, gen)) in enumerate(streams.items())]
    with BagWriter(path) as w:
        for topic, profiles in (qos or {}).items():
            if topic in streams:
                w.add_topic(topic, streams[topic][0], profiles)
        for t_ns, _, topic, msgtype, msg in heapq.merge(*iters, key=lambda x: (x[0], x[1])):
            w.write(topic, msgtype, int(t_ns), serialize(msg, msgtype))
        return dict(w.counts)
