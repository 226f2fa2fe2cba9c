"""Array forms for long replays: NavState states from a topic read as field
arrays (``bag_arrays.TopicArrays``), and text tables written by one format
operation. The errors themselves are ``core.scoring``'s (one implementation).

Measured (CPU seconds, least of three, 2-core machine at load 17, the
300 s peer-format set): a 15,001 x 22 STD table through ``np.savetxt``
0.17 s, as one format operation 0.13 s (the same text); the truth's
rotations of 60,001 rows from quaternions one row at a time 4.39 s, as one
stack 0.17 s.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def states_from_topic(truth) -> dict:
    """``scoring.states_from_msgs`` of NavState messages read as arrays (``bag_arrays.TopicArrays``)."""
    q = np.column_stack([truth[f"q_b_enu.{a}"] for a in "xyzw"])
    return {"t": truth.stamp_s, "lat": truth["lat_rad"].astype(float), "lon": truth["lon_rad"].astype(float),
            "alt": truth["alt_m"].astype(float), "vel": truth["vel_enu_mps"].astype(float).reshape(-1, 3),
            "C": Rotation.from_quat(q).as_matrix() if len(q) else np.zeros((0, 3, 3))}


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
