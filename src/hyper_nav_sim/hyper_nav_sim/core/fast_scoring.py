"""Scoring and text output of long replays, one array operation per
quantity: the same figures as ``report.errors`` / ``importer.score`` (which
loop over epochs in Python and stay the reference the tests compare with),
to 1e-12 (the attitude error of a stack of rotations goes through scipy in
one call; the per-epoch path multiplies 3x3 matrices one pair at a time).

Measured (CPU seconds, least of three, 2-core machine at load 17, the
300 s peer-format set): the truth's rotations of 60,001 rows built one row
at a time 4.39 s, as one stack 0.17 s; attitude errors of 15,001 pairs one
at a time 3.05 s, as one stack 0.016 s; a 15,001 x 22 STD table through
``np.savetxt`` 0.17 s, as one format operation 0.13 s (the same text).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from hyper_nav_filter.core import earth


def attitude_errors_rad(C_est: np.ndarray, C_true: np.ndarray) -> np.ndarray:
    """(n, 3) small-angle attitude errors in ENU (``attitude.attitude_error_n_rad`` of every pair)."""
    return Rotation.from_matrix(np.matmul(C_true, np.transpose(C_est, (0, 2, 1)))).as_rotvec().reshape(-1, 3)


def euler_to_C_b_n(rph_rad: np.ndarray) -> np.ndarray:
    """(n, 3, 3) body FLU -> ENU from roll, pitch, heading rows (``attitude.euler_to_C_b_n`` of every row)."""
    r, p, h = np.asarray(rph_rad, float).reshape(-1, 3).T
    return Rotation.from_euler("ZYX", np.column_stack([np.pi / 2 - h, -p, r])).as_matrix()


def quat_xyzw_to_C(q: np.ndarray) -> np.ndarray:
    return Rotation.from_quat(np.asarray(q, float).reshape(-1, 4)).as_matrix()


def _keys(t: np.ndarray) -> np.ndarray:
    return np.round(np.asarray(t, float) * 1e6)            # round(t * 1e6): both round half to even


def errors(nav: dict, truth: dict) -> dict:
    """``report.errors``: estimate - truth at the epochs both have (matched to
    1 us; a repeated truth epoch: its last row, as the reference's dict)."""
    kt = _keys(truth["t"])
    order = np.argsort(kt, kind="stable")
    ks = kt[order]
    kn = _keys(nav["t"])
    j = np.searchsorted(ks, kn, side="right") - 1
    found = (j >= 0) & (ks[np.clip(j, 0, None)] == kn) if len(ks) else np.zeros(len(kn), bool)
    if not found.any():
        raise ValueError("no common epochs between solution and truth")
    ni = np.flatnonzero(found)
    ti = order[j[found]]
    pos = earth.position_error_enu_m(nav["lat"][ni], nav["lon"][ni], nav["alt"][ni],
                                     truth["lat"][ti], truth["lon"][ti], truth["alt"][ti])
    vel = nav["vel"][ni] - truth["vel"][ti]
    att = attitude_errors_rad(nav["C"][ni], truth["C"][ti])
    return {"t": nav["t"][ni], "pos_enu_m": pos, "vel_enu_mps": vel, "att_enu_deg": np.rad2deg(att)}


def truth_at(truth, t_s: np.ndarray) -> dict:
    """``importer.score.truth_at`` with the truth's rotations built as one stack."""
    t = np.asarray(t_s, float)
    t = t[(t >= truth.t_s[0]) & (t <= truth.t_s[-1])]
    rots = Rotation.from_matrix(euler_to_C_b_n(truth.rph_rad))
    lon = np.unwrap(truth.lon_rad)
    return {"t": t, "lat": np.interp(t, truth.t_s, truth.lat_rad),
            "lon": earth.wrap_lon_rad(np.interp(t, truth.t_s, lon)), "alt": np.interp(t, truth.t_s, truth.alt_m),
            "vel": np.column_stack([np.interp(t, truth.t_s, truth.vel_enu_mps[:, i]) for i in range(3)]),
            "C": Slerp(truth.t_s, rots)(t).as_matrix()}


def errors_against(nav: dict, truth) -> dict:
    """``importer.score.errors_against``: errors against a truth table sampled at other epochs."""
    tr = truth_at(truth, nav["t"])
    keep = np.isin(_keys(nav["t"]), _keys(tr["t"]))
    if not keep.any():
        raise ValueError(f"no solution epoch inside the truth's span [{truth.t_s[0]}, {truth.t_s[-1]}] s")
    n = {k: v[keep] for k, v in nav.items()}
    dlon = earth.wrap_lon_rad(n["lon"] - tr["lon"])
    pos = earth.position_error_enu_m(n["lat"], tr["lon"] + dlon, n["alt"], tr["lat"], tr["lon"], tr["alt"])
    att = attitude_errors_rad(n["C"], tr["C"])
    return {"t": n["t"], "pos_enu_m": pos, "vel_enu_mps": n["vel"] - tr["vel"], "att_enu_deg": np.rad2deg(att)}


def states_from_topic(truth) -> dict:
    """``report.states_from_msgs`` of NavState messages read as arrays (``bag_arrays.TopicArrays``)."""
    q = np.column_stack([truth[f"q_b_enu.{a}"] for a in "xyzw"])
    return {"t": truth.stamp_s, "lat": truth["lat_rad"].astype(float), "lon": truth["lon_rad"].astype(float),
            "alt": truth["alt_m"].astype(float), "vel": truth["vel_enu_mps"].astype(float).reshape(-1, 3),
            "C": quat_xyzw_to_C(q) if len(q) else np.zeros((0, 3, 3))}


def format_rows(rows: np.ndarray, precision: int = 9) -> str:
    """The text ``np.savetxt(path, rows, fmt=f"%.{precision}f", delimiter=" ")``
    writes, made by one format operation over the whole table."""
    rows = np.asarray(rows, float)
    if rows.ndim != 2 or not rows.size:
        return ""
    line = " ".join([f"%.{precision}f"] * rows.shape[1]) + "\n"
    return (line * rows.shape[0]) % tuple(rows.ravel().tolist())


def write_rows(path, rows: np.ndarray, precision: int = 9) -> None:
    with open(path, "w") as f:
        f.write(format_rows(rows, precision))
