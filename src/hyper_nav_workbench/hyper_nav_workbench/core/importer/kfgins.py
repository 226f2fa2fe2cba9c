"""KF-GINS text formats (i2Nav-WHU/KF-GINS README, section 2.2), the first
preset of the importer, and writers of the same formats.

Frames: IMU body forward-right-down (FRD), navigation north-east-down (NED);
attitude as roll, pitch, yaw of FRD w.r.t. NED, which are the aerospace
angles of README "Frames" (our roll, pitch, heading).

  IMU      t (GNSS s of week), dtheta x y z (rad), dvel x y z (m/s): increments
  GNSS     t, lat (deg), lon (deg), h (m), sigma N E D (m)   [13 columns: + vel NED, vel sigma NED]
  .nav     week, t, lat (deg), lon (deg), h (m), vel N E D (m/s), roll pitch yaw (deg)
  STD      t, pos sigma N E D (m), vel sigma N E D (m/s), att sigma roll pitch yaw (deg),
           gyro bias sigma x y z (deg/h), accel bias sigma (mGal), gyro / accel scale sigma (ppm)

``filter_block(config)`` turns a KF-GINS configuration file (``kf-gins.yaml``)
into this project's ``filter:`` block (noise, initial state, lever arm), the
way KF-GINS itself reads it: biases and scale factors Gauss-Markov with one
correlation time, initial IMU-error sigmas defaulting to the noise ones, no
innovation gate.
"""
from __future__ import annotations

import math

import numpy as np

from hyper_nav_filter.core.params import ConfigError

IMU = {"time": {"column": 0, "unit": "s"}, "kind": "increments", "body": "FRD",
       "gyro": {"columns": [1, 2, 3], "unit": "rad"}, "accel": {"columns": [4, 5, 6], "unit": "m/s"}}
GNSS = {"time": {"column": 0, "unit": "s"}, "lat": {"column": 1, "unit": "deg"}, "lon": {"column": 2, "unit": "deg"},
        "alt": {"column": 3, "unit": "m"}, "sigma": {"columns": [4, 5, 6], "unit": "m", "frame": "NED"}}
GNSS_WITH_VELOCITY = {**GNSS, "velocity": {"columns": [7, 8, 9], "frame": "NED"},
                      "vel_sigma": {"columns": [10, 11, 12], "frame": "NED"}}
NAV = {"time": {"column": 1, "unit": "s"}, "lat": {"column": 2, "unit": "deg"}, "lon": {"column": 3, "unit": "deg"},
       "alt": {"column": 4, "unit": "m"}, "velocity": {"columns": [5, 6, 7], "frame": "NED"},
       "attitude": {"columns": [8, 9, 10], "unit": "deg"}}
PRESET = {"imu": IMU, "gnss": GNSS, "truth": NAV}
_FRD = np.array([1.0, -1.0, -1.0])


def preset(stream: str, spec: dict, n_columns: int | None = None) -> dict:
    """The KF-GINS column map of a stream under the user's own fields (a
    13-column GNSS file carries velocities)."""
    base = GNSS_WITH_VELOCITY if stream == "gnss" and n_columns is not None and n_columns >= 13 else PRESET[stream]
    return {**base, **spec}


def _vec(cfg: dict, key: str, n: int = 3) -> list:
    v = cfg.get(key)
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise ConfigError(f"kf-gins config {key}: expected {n} numbers, got {v!r}")
    return [float(x) for x in v]


def filter_block(cfg: dict, t0_s: float | None = None) -> dict:
    """This project's ``filter:`` block (``config`` and ``initial_state``)
    from a KF-GINS configuration mapping; ``t0_s`` is the epoch of the
    initial state (the first IMU record used). Sigmas are per axis in the
    body (FRD and FLU axes coincide in magnitude); NED sigmas become ENU."""
    noise = cfg.get("imunoise") or {}
    ned_to_enu = (lambda v: [v[1], v[0], v[2]])
    tau_s = float(noise.get("corrtime", 1.0)) * 3600.0
    config = {
        "state_blocks": ["att", "vel", "pos", "bg", "ba", "sg", "sa"],
        "gyro_arw_deg_per_sqrt_hr": _vec(noise, "arw"),
        "accel_vrw_mps_per_sqrt_hr": _vec(noise, "vrw"),
        "gyro_bias_sigma_deg_per_hr": _vec(noise, "gbstd"),
        "accel_bias_sigma_mgal": _vec(noise, "abstd"),
        "gyro_scale_factor_sigma_ppm": _vec(noise, "gsstd"),
        "accel_scale_factor_sigma_ppm": _vec(noise, "asstd"),
        "gyro_bias_tau_s": tau_s, "accel_bias_tau_s": tau_s,
        "gyro_scale_factor_tau_s": tau_s, "accel_scale_factor_tau_s": tau_s,
        "init_pos_sigma_m": ned_to_enu(_vec(cfg, "initposstd")),
        "init_vel_sigma_mps": ned_to_enu(_vec(cfg, "initvelstd")),
        # phi about N, E, D <- roll, pitch, yaw sigmas; ENU order: E, N, U
        "init_att_sigma_deg": ned_to_enu(_vec(cfg, "initattstd")),
        "antenna_lever_arm_b_m": (np.asarray(_vec(cfg, "antlever")) * _FRD).tolist(),
        "gate_probability": 1.0,
    }
    for ours, theirs in (("init_gyro_bias_sigma_deg_per_hr", "initbgstd"), ("init_accel_bias_sigma_mgal", "initbastd"),
                         ("init_gyro_scale_factor_sigma_ppm", "initsgstd"),
                         ("init_accel_scale_factor_sigma_ppm", "initsastd")):
        if theirs in cfg:
            config[ours] = _vec(cfg, theirs)
    init = {
        "lat_deg": _vec(cfg, "initpos")[0], "lon_deg": _vec(cfg, "initpos")[1], "alt_m": _vec(cfg, "initpos")[2],
        "vel_ned_mps": _vec(cfg, "initvel"), "roll_pitch_heading_deg": _vec(cfg, "initatt"),
        # biases: FRD -> FLU (y and z change sign); scale factors are per axis, sign-free
        "gyro_bias_deg_per_hr": (np.asarray(_vec(cfg, "initgyrbias")) * _FRD).tolist(),
        "accel_bias_mgal": (np.asarray(_vec(cfg, "initaccbias")) * _FRD).tolist(),
        "gyro_scale_factor_ppm": _vec(cfg, "initgyrscale"), "accel_scale_factor_ppm": _vec(cfg, "initaccscale"),
    }
    if t0_s is not None:
        init["t_s"] = float(t0_s)
    return {"config": config, "initial_state": init}


def window_of(cfg: dict) -> tuple[float | None, float | None]:
    """(start, end) of the processing interval of a KF-GINS configuration (None = open)."""
    start = cfg.get("starttime")
    end = cfg.get("endtime")
    return (None if start in (None, 0) else float(start)), (None if end in (None, -1, 0) else float(end))


# ---- writers -------------------------------------------------------------------------
def nav_rows(t_s, lat_rad, lon_rad, alt_m, vel_enu_mps, rph_rad) -> np.ndarray:
    """Rows of a KF-GINS .nav file (week set to 0, as KF-GINS writes it)."""
    v = np.asarray(vel_enu_mps, float)
    rph = np.rad2deg(np.asarray(rph_rad, float))
    heading = np.mod(rph[:, 2], 360.0)
    return np.column_stack([np.zeros(len(t_s)), t_s, np.rad2deg(lat_rad), np.rad2deg(lon_rad), alt_m,
                            v[:, 1], v[:, 0], -v[:, 2], rph[:, 0], rph[:, 1], heading])


def std_rows(t_s, sigma_blocks: dict) -> np.ndarray:
    """Rows of a KF-GINS STD file from per-block 1-sigma arrays (n, 3) in the
    ENU error convention and SI: pos (m), vel (m/s), att (rad), bg (rad/s),
    ba (m/s^2), sg, sa (dimensionless). A block the filter does not carry is
    written as NaN."""
    n = len(t_s)
    nan3 = np.full((n, 3), np.nan)

    def ned(x):
        return np.column_stack([x[:, 1], x[:, 0], x[:, 2]])
    g = sigma_blocks.get
    cols = [np.asarray(t_s, float)[:, None], ned(g("pos", nan3)), ned(g("vel", nan3)), np.rad2deg(ned(g("att", nan3))),
            g("bg", nan3) * 180.0 / math.pi * 3600.0, g("ba", nan3) * 1e5, g("sg", nan3) * 1e6, g("sa", nan3) * 1e6]
    return np.hstack(cols)


def write_rows(path, rows: np.ndarray, precision: int = 9) -> None:
    np.savetxt(path, rows, fmt=f"%.{precision}f", delimiter=" ")
