"""Attitude conventions and helpers (REP-103).

Body frame b is FLU (x forward, y left, z up); navigation frame n is ENU.
``C_b_n`` rotates body vectors into ENU. Euler angles are the aerospace ones
users quote: roll (right wing down positive), pitch (nose up positive) and
heading (clockwise from true north), applied as heading, pitch, roll:

    C_b_n = Rz(pi/2 - heading) @ Ry(-pitch) @ Rx(roll)

so that heading = 0 and pitch = 0 points the nose north, in the horizontal
plane. ``scipy.spatial.transform.Rotation`` does the rotation algebra.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation


def skew(v):
    """Cross-product matrix [v x]."""
    return np.array([[0.0, -v[2], v[1]],
                     [v[2], 0.0, -v[0]],
                     [-v[1], v[0], 0.0]])


def euler_to_C_b_n(roll_rad, pitch_rad, heading_rad):
    """Direction cosine matrix body(FLU) -> ENU from aerospace Euler angles."""
    return Rotation.from_euler("ZYX", [np.pi / 2 - heading_rad, -pitch_rad, roll_rad]).as_matrix()


def C_b_n_to_euler(C_b_n):
    """Inverse of :func:`euler_to_C_b_n`: (roll, pitch, heading) in rad,
    heading wrapped to [0, 2 pi). Closed form for a single matrix (scipy's
    Rotation.from_matrix(...).as_euler costs ~30 us per call on this
    project's machines, this ~2 us; they agree to 1e-12, tested); stacks of
    matrices go through scipy."""
    C = np.asarray(C_b_n, float)
    if C.ndim == 3:
        z, y, x = Rotation.from_matrix(C).as_euler("ZYX").T
        return x, -y, np.mod(np.pi / 2 - z, 2 * np.pi)
    # C = Rz(z) Ry(y) Rx(x) with z = pi/2 - heading, y = -pitch, x = roll
    c_y = math.hypot(C[2, 1], C[2, 2])
    y = math.atan2(-C[2, 0], c_y)            # well conditioned near +-90 deg (asin is not)
    if c_y > 1e-12:
        z = math.atan2(C[1, 0], C[0, 0])
        x = math.atan2(C[2, 1], C[2, 2])
    else:                               # gimbal lock: roll folded into heading, as scipy does
        z = math.atan2(-C[0, 1], C[1, 1])
        x = 0.0
    return x, -y, (math.pi / 2 - z) % (2 * math.pi)


def cross3(a, b):
    """Cross product of two 3-vectors (np.cross costs ~40 us per call on
    3-vectors with numpy 2.2; this ~2 us, measured on this project's machines)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def rotvec_to_C(phi):
    """Rotation matrix of a rotation vector (Rodrigues). Hand-written for the
    per-epoch INS loop: scipy's Rotation.from_rotvec(...).as_matrix() costs
    ~39 us per single vector here, this ~6 us; they agree to 1e-15 (tested)."""
    angle2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]
    K = skew(phi)
    if angle2 < 1e-12:
        # series to 2nd order is exact to double precision below 1e-6 rad
        return np.eye(3) + K + 0.5 * (K @ K)
    angle = np.sqrt(angle2)
    return np.eye(3) + (np.sin(angle) / angle) * K + ((1.0 - np.cos(angle)) / angle2) * (K @ K)


def C_to_quat_xyzw(C):
    """Unit quaternion (x, y, z, w), scalar last as in geometry_msgs, w >= 0.
    Shepperd's method for a single matrix (scipy ~25 us per call here, this
    ~2 us; equal to scipy's to 1e-12, tested); stacks go through scipy."""
    C = np.asarray(C, float)
    if C.ndim == 3:
        return Rotation.from_matrix(C).as_quat()
    # the elements as Python floats first: numpy scalar indexing was 8 of this function's 10 us
    # (the same IEEE operations: the same quaternion to the bit)
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = C.tolist()
    tr = c00 + c11 + c22
    if tr > max(c00, c11, c22):
        w = 0.5 * math.sqrt(1.0 + tr)
        q = ((c21 - c12) / (4 * w), (c02 - c20) / (4 * w), (c10 - c01) / (4 * w), w)
    elif c00 >= c11 and c00 >= c22:
        x = 0.5 * math.sqrt(1.0 + 2 * c00 - tr)
        q = (x, (c01 + c10) / (4 * x), (c02 + c20) / (4 * x), (c21 - c12) / (4 * x))
    elif c11 >= c22:
        y = 0.5 * math.sqrt(1.0 + 2 * c11 - tr)
        q = ((c01 + c10) / (4 * y), y, (c12 + c21) / (4 * y), (c02 - c20) / (4 * y))
    else:
        z = 0.5 * math.sqrt(1.0 + 2 * c22 - tr)
        q = ((c02 + c20) / (4 * z), (c12 + c21) / (4 * z), z, (c10 - c01) / (4 * z))
    q = np.array(q)
    q /= math.sqrt(q @ q)
    return -q if q[3] < 0 else q


def quat_xyzw_to_C(q):
    return Rotation.from_quat(q).as_matrix()


def attitude_error_n_rad(C_b_n_est, C_b_n_true):
    """Small-angle attitude error phi in ENU [rad]: C_est = (I - [phi x]) C_true,
    i.e. the rotation vector of C_true @ C_est^T."""
    return Rotation.from_matrix(C_b_n_true @ C_b_n_est.T).as_rotvec()


def orthonormalize(C):
    """Remove numerical drift from a nearly orthonormal matrix with one
    first-order step toward the nearest rotation, C - C (C^T C - I) / 2
    (exact to second order in the drift, which is ~1e-16 per INS step)."""
    return C - 0.5 * C @ (C.T @ C - np.eye(3))
