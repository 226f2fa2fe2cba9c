"""Message <-> core conversions of the geomagnetic node, duck-typed (rclpy
messages live, rosbags messages offline); no rclpy import.

* sensor_msgs/MagneticField (tesla, body FLU) -> MagSample: |B| in nT (the
  norm does not depend on the attitude; hard/soft iron are taken as
  calibrated out).
* hyper_nav_msgs/NavState -> NavPoint: position, ENU velocity, the
  position block of the covariance (found by name in ``state_blocks``) and
  the acceleration w.r.t. Earth in ENU, C_b_n f_b + g - (2 w_ie + w_en) x v
  (from ``accel_b_mps2``, the compensated specific force, and ``q_b_enu``).
* MatchResult -> sensor_msgs/NavSatFix fields: the fix, ENU
  ``position_covariance`` whose EN block is the fix covariance and whose
  vertical variance is ``NO_VERTICAL_VAR_M2`` (the fix says nothing about
  height; the altitude field repeats the solution's); a 3-D fix (the EKF's
  pseudo-fix along the 3-D gradient) carries its altitude and full ENU
  covariance instead (degenerate: information along one direction only);
  and hyper_nav_msgs/MatchQuality fields.
* MatchResult -> the fusion core's measurement (offline runs: what the
  fusion node's declared source makes of the published fix).
"""
from __future__ import annotations

import numpy as np

from hyper_nav_filter.conversions import s_to_stamp_fields, stamp_to_s
from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import quat_xyzw_to_C
from hyper_nav_filter.core.measurements import HorizontalFix, PositionFix

from hyper_nav_aiding.geomag.core.matching import MagSample, MatchResult, NavPoint

NO_VERTICAL_VAR_M2 = 1.0e12
STATUS_FIX, STATUS_NO_FIX, SERVICE_UNKNOWN, COVARIANCE_TYPE_KNOWN = 0, -1, 0, 3


def mag_sample(msg) -> MagSample:
    f = msg.magnetic_field
    return MagSample(stamp_to_s(msg.header.stamp), float(np.sqrt(f.x**2 + f.y**2 + f.z**2)) * 1e9)


def position_block(state_blocks) -> slice | None:
    """Slice of the 'pos' block in a NavState covariance, from its
    ``state_blocks`` (["att:3", "vel:3", "pos:3", ...])."""
    start = 0
    for b in state_blocks:
        name, _, size = str(b).partition(":")
        try:
            n = int(size)
        except ValueError:
            return None
        if name == "pos":
            return slice(start, start + n)
        start += n
    return None


def nav_point(msg) -> NavPoint:
    """NavState -> NavPoint; NaN covariance when the message has none."""
    cov = np.full((2, 2), np.nan)
    alt_var = float("nan")
    sl = position_block(msg.state_blocks)
    n = int(msg.state_dim)
    c = np.asarray(msg.covariance, float)
    if sl is not None and n > 0 and c.size == n * n and sl.stop <= n:
        P = c.reshape(n, n)[sl, sl]
        cov, alt_var = P[:2, :2].copy(), float(P[2, 2])
    lat, alt = float(msg.lat_rad), float(msg.alt_m)
    v = np.asarray(msg.vel_enu_mps, float).copy()
    q = msg.q_b_enu
    acc = np.zeros(3)
    if all(np.isfinite([q.x, q.y, q.z, q.w])) and abs(q.x**2 + q.y**2 + q.z**2 + q.w**2 - 1.0) < 1e-3:
        C = quat_xyzw_to_C([q.x, q.y, q.z, q.w])
        acc = (C @ np.asarray(msg.accel_b_mps2, float) + earth.gravity_n(lat, alt)
               - np.cross(2.0 * earth.omega_ie_n(lat) + earth.omega_en_n(lat, alt, v), v))
    return NavPoint(stamp_to_s(msg.header.stamp), lat, float(msg.lon_rad), alt, v, cov, alt_var, acc)


def _header(t_s: float, frame: str) -> dict:
    sec, nsec = s_to_stamp_fields(t_s)
    return {"header.stamp.sec": sec, "header.stamp.nanosec": nsec, "header.frame_id": frame}


def navsatfix_fields(res: MatchResult, alt_m: float, frame_id: str) -> dict:
    if res.cov_enu_m2 is not None:
        cov, alt_m = np.asarray(res.cov_enu_m2, float), res.alt_m
    else:
        cov = np.zeros((3, 3))
        cov[:2, :2] = res.cov_en_m2
        cov[2, 2] = NO_VERTICAL_VAR_M2
    d = _header(res.t_s, frame_id)
    d.update({"status.status": STATUS_FIX, "status.service": SERVICE_UNKNOWN,
              "latitude": float(np.rad2deg(res.lat_rad)), "longitude": float(np.rad2deg(res.lon_rad)),
              "altitude": float(alt_m), "position_covariance": cov.ravel().tolist(),
              "position_covariance_type": COVARIANCE_TYPE_KNOWN})
    return d


def match_quality_fields(res: MatchResult, frame_id: str) -> dict:
    d = _header(res.t_s, frame_id)

    def num(x):
        return float(x) if np.isfinite(x) else float("nan")
    d.update({"algorithm": res.algorithm, "valid": bool(res.valid), "reason": res.reason[:200],
              "metric": num(res.metric), "iterations": int(res.iterations),
              "sequence_length": int(res.sequence_length),
              "along_gradient_sigma_m": num(res.along_gradient_sigma_m),
              "across_gradient_sigma_m": num(res.across_gradient_sigma_m),
              "gradient_nt_per_km": num(res.gradient_nt_per_km), "compute_time_s": float(res.compute_time_s),
              "map_epoch_bias_nt": num(res.map_epoch_bias_nT)})
    return d


def fix_measurement(res):
    """The fusion measurement of a fix, as the fusion node's declared source
    converts it: horizontal (``horizontal_fix`` -> ``HorizontalFix``, seed 003
    eqs. 20-26) or, for a 3-D fix, ``position_fix`` -> ``PositionFix`` with
    the full ENU covariance."""
    if res.cov_enu_m2 is not None:
        return PositionFix(res.t_s, res.lat_rad, res.lon_rad, res.alt_m, res.cov_enu_m2)
    return HorizontalFix(res.t_s, res.lat_rad, res.lon_rad, res.cov_en_m2)
