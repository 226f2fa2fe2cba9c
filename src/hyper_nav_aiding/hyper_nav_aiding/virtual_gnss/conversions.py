"""Message <-> core conversions of the virtual GNSS node, duck-typed (rclpy
or rosbags messages), no rclpy import: the node and the offline replay use
the same functions. Receiver messages (GnssMeasurements, GnssEphemeris,
Imu stamps) go through :mod:`hyper_nav_filter.conversions`."""
from __future__ import annotations

import numpy as np

from hyper_nav_filter.conversions import GNSS_SYSTEMS, s_to_stamp_fields, stamp_to_s
from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import quat_xyzw_to_C
from hyper_nav_gnss.orbits.ephemeris import C_MPS, SECONDS_PER_WEEK
from hyper_nav_gnss.corrections.propagation import CARRIER_HZ
from hyper_nav_filter.core.nav_state import ImuSample, NavState

SYSTEM_CODES = {s: code for code, s in GNSS_SYSTEMS.items()}      # 'G' -> 1 (SYSTEM_GPS), 'C' -> 3


def nav_state(msg) -> tuple[NavState, float]:
    """hyper_nav_msgs/NavState -> (NavState, per-axis position 1-sigma [m] from
    the ``pos`` block of the covariance; 0 if none)."""
    q = msg.q_b_enu
    s = NavState(stamp_to_s(msg.header.stamp), float(msg.lat_rad), float(msg.lon_rad), float(msg.alt_m),
                 np.asarray(msg.vel_enu_mps, float).copy(), quat_xyzw_to_C([q.x, q.y, q.z, q.w]),
                 np.asarray(msg.gyro_bias_b_radps, float).copy(), np.asarray(msg.accel_bias_b_mps2, float).copy())
    sigma, start = 0.0, 0
    n = int(msg.state_dim)
    for block in msg.state_blocks:
        name, size = block.split(":")
        if name == "pos" and n:
            P = np.asarray(msg.covariance, float).reshape(n, n)[start:start + 3, start:start + 3]
            sigma = float(np.sqrt(max(np.trace(P), 0.0) / 3.0))
        start += int(size)
    return s, sigma


def fix_ecef(fix_msg) -> tuple[float, np.ndarray]:
    """sensor_msgs/NavSatFix -> (t_s, antenna ECEF position [m])."""
    return stamp_to_s(fix_msg.header.stamp), earth.geodetic_to_ecef(
        np.deg2rad(fix_msg.latitude), np.deg2rad(fix_msg.longitude), float(fix_msg.altitude))


def vel_ecef(vel_msg, lat_rad: float, lon_rad: float) -> tuple[float, np.ndarray]:
    """geometry_msgs/TwistWithCovarianceStamped (ENU) -> (t_s, ECEF velocity [m/s])."""
    v = vel_msg.twist.twist.linear
    return stamp_to_s(vel_msg.header.stamp), earth.C_n_e(lat_rad, lon_rad) @ np.array([v.x, v.y, v.z])


def imu_sample(msg, t_prev_s: float | None) -> ImuSample | None:
    """sensor_msgs/Imu (mean rates over (previous stamp, stamp], README) ->
    ImuSample; None for the first message (no interval yet) or a stamp not
    after the previous one."""
    t = stamp_to_s(msg.header.stamp)
    if t_prev_s is None or t <= t_prev_s:
        return None
    dt = t - t_prev_s
    w, a = msg.angular_velocity, msg.linear_acceleration
    return ImuSample(t, dt, np.array([w.x, w.y, w.z]) * dt, np.array([a.x, a.y, a.z]) * dt)


def fill_gnss_measurements(msg, epoch, elevation_rad, azimuth_rad, frame_id: str, virtual: bool = True):
    """Fill a hyper_nav_msgs/GnssMeasurements from a RawGnssEpoch. Virtual
    (default): every channel ``locked`` (usable) and ``is_virtual``, no
    signal so C/N0 0; else the epoch's lock flags, ``is_virtual`` empty
    (a receiver epoch, for offline studies). Doppler from the rate."""
    msg.header.stamp.sec, msg.header.stamp.nanosec = s_to_stamp_fields(epoch.t_s)
    msg.header.frame_id = frame_id
    week = int(epoch.t_rx_gpst_s // SECONDS_PER_WEEK)
    msg.gps_week = week
    msg.rx_time_of_week_s = float(epoch.t_rx_gpst_s - week * SECONDS_PER_WEEK)
    f = np.array([CARRIER_HZ[s] for s in epoch.system])
    msg.system = [SYSTEM_CODES[s] for s in epoch.system]
    msg.prn = [int(p) for p in epoch.prn]
    for name, arr in (("pseudorange_m", epoch.pseudorange_m), ("pseudorange_sigma_m", epoch.pseudorange_sigma_m),
                      ("pseudorange_rate_mps", epoch.rate_mps), ("pseudorange_rate_sigma_mps", epoch.rate_sigma_mps),
                      ("doppler_hz", -np.asarray(epoch.rate_mps) * f / C_MPS), ("carrier_frequency_hz", f),
                      ("cn0_dbhz", np.zeros(len(f))), ("elevation_rad", elevation_rad), ("azimuth_rad", azimuth_rad)):
        setattr(msg, name, [float(x) for x in arr])
    msg.locked = [True] * len(f) if virtual else [bool(x) for x in epoch.locked]
    msg.is_virtual = [True] * len(f) if virtual else []
    return msg
