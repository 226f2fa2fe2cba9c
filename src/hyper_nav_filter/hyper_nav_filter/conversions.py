"""Message <-> core conversions, duck-typed so the same code takes rclpy
messages (live node) and rosbags-deserialized messages (offline replay).
No rclpy import here.

sensor_msgs/Imu mapping (documented in the README): the IMU node integrates
over (previous stamp, header.stamp]; ``angular_velocity`` = delta-theta / dt
and ``linear_acceleration`` = delta-v / dt (FLU body, rad/s and m/s^2, float64),
so increments are recovered exactly as rate * (stamp - previous stamp).
"""
from __future__ import annotations

import numpy as np

from .core.measurements import GnssPosition, GnssVelocity


def stamp_to_s(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def s_to_stamp_fields(t_s: float) -> tuple[int, int]:
    ns = int(round(t_s * 1e9))
    return ns // 1_000_000_000, ns % 1_000_000_000


def imu_rates(msg):
    """(t_s, omega_b_radps, f_b_mps2) of a sensor_msgs/Imu."""
    w, a = msg.angular_velocity, msg.linear_acceleration
    return stamp_to_s(msg.header.stamp), np.array([w.x, w.y, w.z]), np.array([a.x, a.y, a.z])


def gnss_position(msg) -> GnssPosition:
    """sensor_msgs/NavSatFix -> GnssPosition. The message covariance is in
    ENU (m^2, row-major, REP-145)."""
    cov = np.asarray(msg.position_covariance, dtype=float).reshape(3, 3)
    return GnssPosition(stamp_to_s(msg.header.stamp), np.deg2rad(msg.latitude), np.deg2rad(msg.longitude),
                        float(msg.altitude), cov)


def gnss_velocity(msg) -> GnssVelocity:
    """geometry_msgs/TwistWithCovarianceStamped (ENU frame) -> GnssVelocity;
    the linear block of the 6x6 covariance is used."""
    v = msg.twist.twist.linear
    cov = np.asarray(msg.twist.covariance, dtype=float).reshape(6, 6)[:3, :3]
    return GnssVelocity(stamp_to_s(msg.header.stamp), np.array([v.x, v.y, v.z]), cov)
