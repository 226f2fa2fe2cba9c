"""Message <-> core conversions, duck-typed so the same code takes rclpy
messages (live node) and rosbags-deserialized messages (offline replay).
No rclpy import here.

sensor_msgs/Imu mapping (documented in the README): the IMU node integrates
over (previous stamp, header.stamp]; ``angular_velocity`` = delta-theta / dt
and ``linear_acceleration`` = delta-v / dt (FLU body, rad/s and m/s^2, float64),
so increments are recovered exactly as rate * (stamp - previous stamp).

hyper_nav_msgs/GnssMeasurements and GnssEphemeris map to the tightly coupled
core types (``hyper_nav_gnss.observations.RawGnssEpoch``,
``core.gnss.ephemeris.BroadcastEphemeris``); system codes 1 (GPS) -> 'G',
2 (Galileo) -> 'E', 3 (BDS) -> 'C', 5 (QZSS) -> 'J', 6 (GLONASS) -> 'R',
others -> '?<code>' (dropped as unsupported downstream). The per-signal
arrays (signal code, carrier phase, lock time, tracking flags) are carried
when the message has them (empty = not reported).
"""
from __future__ import annotations

import numpy as np

from hyper_nav_gnss.orbits.ephemeris import SECONDS_PER_WEEK, BroadcastEphemeris
from hyper_nav_gnss.observations import RawGnssEpoch
from hyper_nav_gnss.signals import SYSTEM_OF_MSG
from .core.measurements import GnssPosition, GnssVelocity

GNSS_SYSTEMS = dict(SYSTEM_OF_MSG)       # hyper_nav_msgs SYSTEM_GPS 1, _GAL 2, _BDS 3, _QZSS 5, _GLO 6


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


def _stamps_s(fields: dict) -> list[float]:
    """``stamp_to_s`` over a topic's header stamp columns."""
    return (fields["header.stamp.sec"] + fields["header.stamp.nanosec"] * 1e-9).tolist()


def gnss_positions(fields: dict) -> list[GnssPosition]:
    """``gnss_position`` over a NavSatFix topic read into arrays ({dotted
    field path: column}, ``hyper_nav_workbench.core.bag_arrays``): the same values,
    message for message (no status or covariance-type checks here, as there)."""
    lat = np.deg2rad(fields["latitude"].astype(float)).tolist()
    lon = np.deg2rad(fields["longitude"].astype(float)).tolist()
    alt = fields["altitude"].astype(float).tolist()
    cov = np.asarray(fields["position_covariance"], dtype=float).reshape(-1, 3, 3)
    return [GnssPosition(t, la, lo, h, c) for t, la, lo, h, c in zip(_stamps_s(fields), lat, lon, alt, cov)]


def gnss_velocities(fields: dict) -> list[GnssVelocity]:
    """``gnss_velocity`` over a TwistWithCovarianceStamped topic read into arrays."""
    v = np.column_stack([fields[f"twist.twist.linear.{a}"] for a in "xyz"]).astype(float)
    cov = np.asarray(fields["twist.covariance"], dtype=float).reshape(-1, 6, 6)[:, :3, :3]
    return [GnssVelocity(t, vi, c) for t, vi, c in zip(_stamps_s(fields), v, cov)]


def _system(code) -> str:
    return GNSS_SYSTEMS.get(int(code), f"?{int(code)}")


def gnss_raw(msg) -> RawGnssEpoch:
    """hyper_nav_msgs/GnssMeasurements -> RawGnssEpoch (no validation here:
    the core checks lengths and values, ``check_raw_epoch``)."""
    def arr(name, dtype=float):
        return np.asarray(list(getattr(msg, name, ())), dtype=dtype)
    return RawGnssEpoch(
        stamp_to_s(msg.header.stamp), float(msg.gps_week) * SECONDS_PER_WEEK + float(msg.rx_time_of_week_s),
        tuple(_system(c) for c in msg.system), arr("prn", int), arr("pseudorange_m"),
        arr("pseudorange_sigma_m"), arr("pseudorange_rate_mps"), arr("pseudorange_rate_sigma_mps"),
        arr("locked", bool), tuple(str(c) for c in getattr(msg, "signal", ())), arr("carrier_phase_cycles"),
        arr("doppler_hz"), arr("cn0_dbhz"), arr("lock_time_s"), arr("tracking_flags", np.uint8),
        arr("carrier_frequency_hz"))


def gnss_ephemeris(msg) -> BroadcastEphemeris:
    """hyper_nav_msgs/GnssEphemeris -> BroadcastEphemeris (times of week in the
    system's own scale, as in the message)."""
    return BroadcastEphemeris(
        _system(msg.system), int(msg.prn), float(msg.toe_s), float(msg.toc_s), int(msg.week),
        float(msg.sqrt_a_sqrtm), float(msg.e), float(msg.i0_rad), float(msg.omega0_rad), float(msg.omega_rad),
        float(msg.m0_rad), float(msg.delta_n_radps), float(msg.idot_radps), float(msg.omega_dot_radps),
        float(msg.cuc_rad), float(msg.cus_rad), float(msg.crc_m), float(msg.crs_m), float(msg.cic_rad),
        float(msg.cis_rad), float(msg.af0_s), float(msg.af1_sps), float(msg.af2_sps2), float(msg.tgd_s),
        iode=int(getattr(msg, "iode", -1)), health=int(getattr(msg, "health", 0)),
        tgd2=float(getattr(msg, "tgd2_s", 0.0)), data_source=int(getattr(msg, "data_source", 0)),
        accuracy_m=float(getattr(msg, "accuracy_m", 0.0)))


def gnss_ephemeris_klobuchar(msg):
    """(system, alpha[4], beta[4]) of a GnssEphemeris that carries Klobuchar
    coefficients, else None."""
    a, b = list(getattr(msg, "klobuchar_alpha", ())), list(getattr(msg, "klobuchar_beta", ()))
    if len(a) != 4 or len(b) != 4:
        return None
    return _system(msg.system), np.asarray(a, float), np.asarray(b, float)
