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

import math

import numpy as np
from scipy.spatial.transform import Rotation


def states_from_topic(truth) -> dict:
    """``scoring.states_from_msgs`` of NavState messages read as arrays (``bag_arrays.TopicArrays``)."""
    q = np.column_stack([truth[f"q_b_enu.{a}"] for a in "xyzw"])
    return {"t": truth.stamp_s, "lat": truth["lat_rad"].astype(float), "lon": truth["lon_rad"].astype(float),
            "alt": truth["alt_m"].astype(float), "vel": truth["vel_enu_mps"].astype(float).reshape(-1, 3),
            "C": Rotation.from_quat(q).as_matrix() if len(q) else np.zeros((0, 3, 3))}


# libm's atan2 and hypot element by element (numpy's own loops run them in C over the array): numpy's SIMD
# arctan2 and hypot differ from libm in the last bit (AVX-512 machine, numpy 2.2: arctan2 on 7 % of random
# arguments, hypot on 0.6 %), which moves 9th decimals of the .nav text
_atan2 = np.frompyfunc(math.atan2, 2, 1)
_hypot = np.frompyfunc(math.hypot, 2, 1)


def euler_rows(C_b_n) -> np.ndarray:
    """(n, 3) roll, pitch, heading (rad, heading in [0, 2 pi)) of a stack of
    C_b_n (n, 3, 3): ``attitude.C_b_n_to_euler``'s closed form for one matrix,
    applied column-wise with the same float operations in the same order, so
    the same numbers bit for bit (scipy's stack, the function's own branch
    for a stack, agrees to 1e-12 rad only). Peer-format set, 168,101
    matrices: one call per matrix 0.19 s, this 0.05 s (CPU, same process)."""
    C = np.asarray(C_b_n, float).reshape(-1, 3, 3)

    def f(fn, a, b):
        return fn(a, b).astype(float) if len(a) else np.zeros(0)
    c_y = f(_hypot, C[:, 2, 1], C[:, 2, 2])
    y = f(_atan2, -C[:, 2, 0], c_y)
    ok = c_y > 1e-12
    z = np.empty(len(C))
    x = np.zeros(len(C))                       # gimbal lock: roll folded into heading, as scipy does
    z[ok] = f(_atan2, C[ok, 1, 0], C[ok, 0, 0])
    x[ok] = f(_atan2, C[ok, 2, 1], C[ok, 2, 2])
    z[~ok] = f(_atan2, -C[~ok, 0, 1], C[~ok, 1, 1])
    return np.column_stack([x, -y, (math.pi / 2 - z) % (2 * math.pi)])


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
