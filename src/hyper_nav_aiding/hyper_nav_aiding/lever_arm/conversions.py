"""Message <-> core conversions of the lever-arm learning node, duck-typed
(rclpy or rosbags messages), no rclpy import.

``hyper_nav_msgs/NavState`` -> (core NavState, covariance): the nominal
navigation state and biases; the message carries no nominal values of the
optional blocks (``gm``, ``lev``), so a replay starts the modes at their static
deflection (as the filter does at start-up). The covariance is returned only
when the message's ``state_blocks`` are the layout the node replays with.

Re-estimation result -> ``hyper_nav_msgs/ModelUpdate`` fields: model
"lever_arm", the name ``lever_arm_natural_freq_radps`` repeated for its three
values in order (the form ModelUpdate.msg documents), 1-sigma from the
Cramer-Rao bound at the estimate.
"""
from __future__ import annotations

import numpy as np

from hyper_nav_filter.conversions import s_to_stamp_fields, stamp_to_s
from hyper_nav_filter.core.attitude import quat_xyzw_to_C
from hyper_nav_filter.core.nav_state import NavState

from hyper_nav_aiding.lever_arm.core.replay import FREQ_FIELD

MODEL_NAME = "lever_arm"


def navstate(msg, layout) -> tuple[NavState, np.ndarray]:
    """(state, P) of a NavState message; ValueError when it is not finite or
    its state blocks are not ``layout``'s."""
    q = msg.q_b_enu
    s = NavState(stamp_to_s(msg.header.stamp), float(msg.lat_rad), float(msg.lon_rad), float(msg.alt_m),
                 np.asarray(msg.vel_enu_mps, float), quat_xyzw_to_C([q.x, q.y, q.z, q.w]),
                 np.asarray(msg.gyro_bias_b_radps, float), np.asarray(msg.accel_bias_b_mps2, float))
    vals = [s.t_s, s.lat_rad, s.lon_rad, s.alt_m, *s.vel_enu_mps, q.x, q.y, q.z, q.w,
            *s.gyro_bias_b_radps, *s.accel_bias_b_mps2]
    if not np.all(np.isfinite(vals)):
        raise ValueError("nan")
    if list(msg.state_blocks) != list(layout.describe()) or int(msg.state_dim) != layout.dim:
        raise ValueError("layout")
    P = np.asarray(msg.covariance, float)
    if P.size != layout.dim**2 or not np.all(np.isfinite(P)):
        raise ValueError("covariance")
    return s, P.reshape(layout.dim, layout.dim)


def model_update_fields(t_apply_s: float, freqs_radps, sigmas_radps, origin: str, note: str) -> dict:
    sec, nsec = s_to_stamp_fields(t_apply_s)
    sig = [] if sigmas_radps is None else [float(x) for x in sigmas_radps]
    return {"header.stamp.sec": sec, "header.stamp.nanosec": nsec, "header.frame_id": "",
            "model": MODEL_NAME, "names": [FREQ_FIELD] * 3, "values": [float(x) for x in freqs_radps],
            "sigmas": sig, "origin": origin, "note": note}


def model_update_frequencies(msg):
    """(epoch, frequencies) of a lever-arm ModelUpdate, or None for another model."""
    if msg.model != MODEL_NAME:
        return None
    vals = [v for n, v in zip(msg.names, msg.values) if n.split("[")[0] == FREQ_FIELD]
    return stamp_to_s(msg.header.stamp), np.asarray(vals, float)
