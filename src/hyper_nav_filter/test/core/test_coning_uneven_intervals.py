"""Two-sample coning and sculling terms on uneven IMU intervals
(``mechanization.two_sample_divisor``), against analytic truth.

Coning: the classical coning motion (Savage 1998, Strapdown Analytics
sec. 7.1.1.1): body attitude q(t) = [cos(a/2), sin(a/2) cos(W t),
sin(a/2) sin(W t), 0] (scalar first, body to reference), whose body rate
w_b = 2 vec(q* q') has a rectified component about x; integrated with
rotation increments alone the attitude drifts about x. The gyro increments
are the integrals of w_b over each interval (Gauss-Legendre, exact to
1e-15 here) on a jittered time line (150 Hz nominal, intervals uniform
in +/-40 %); the attitude after 10 s is compared with q(10 s)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hyper_nav_filter.core import mechanization
from hyper_nav_filter.core.attitude import rotvec_to_C

HALF_CONE_RAD = np.deg2rad(2.0)
CONE_HZ = 5.0                      # handheld-walk vibration band
RATE_HZ = 150.0
DURATION_S = 10.0


def _quat(t):
    """q(t) of the coning motion, scalar first, and its time derivative."""
    a, W = HALF_CONE_RAD, 2 * np.pi * CONE_HZ
    s = np.sin(a / 2)
    q = np.stack([np.full_like(t, np.cos(a / 2)), s * np.cos(W * t), s * np.sin(W * t), np.zeros_like(t)], -1)
    qd = np.stack([np.zeros_like(t), -s * W * np.sin(W * t), s * W * np.cos(W * t), np.zeros_like(t)], -1)
    return q, qd


def _body_rate(t):
    """w_b = 2 vec(conj(q) * q') (rad/s), rows per time."""
    q, qd = _quat(t)
    w0, v0 = q[..., 0], -q[..., 1:]            # conj(q)
    w1, v1 = qd[..., 0], qd[..., 1:]
    vec = w0[..., None] * v1 + w1[..., None] * v0 + np.cross(v0, v1)
    return 2.0 * vec


def _increments(t_edges):
    """Exact gyro increments over [t_edges[k-1], t_edges[k]] (8-point Gauss-Legendre)."""
    x, w = np.polynomial.legendre.leggauss(8)
    a, b = t_edges[:-1], t_edges[1:]
    tt = 0.5 * (b - a)[:, None] * x[None, :] + 0.5 * (a + b)[:, None]
    return 0.5 * (b - a)[:, None] * np.einsum("j,kjd->kd", w, _body_rate(tt))


def _C_true(t):
    q, _ = _quat(np.atleast_1d(np.asarray(t, float)))
    return Rotation.from_quat(q[0, [1, 2, 3, 0]]).as_matrix()


def _attitude_error_rad(t_edges, mode):
    """|rotation vector| of C_est C_true^T at the end: mode 'none' (rotation
    increments only), 'equal' (1/12 weight whatever the intervals), 'uneven'
    (two_sample_divisor)."""
    dth = _increments(t_edges)
    dts = np.diff(t_edges)
    C = _C_true(t_edges[0])
    prev = None
    for k in range(len(dth)):
        if prev is None or mode == "none":
            phi = dth[k]
        else:
            kk = 12.0 if mode == "equal" else mechanization.two_sample_divisor(dts[k], dts[k - 1])
            phi = mechanization.coning_rotation_vector(dth[k], prev, kk)
        C = C @ rotvec_to_C(phi)
        prev = dth[k]
    return float(np.linalg.norm(Rotation.from_matrix(C @ _C_true(t_edges[-1]).T).as_rotvec()))


def _time_line(jitter, seed=0):
    rng = np.random.default_rng(seed)
    n = int(DURATION_S * RATE_HZ)
    dt = (1.0 / RATE_HZ) * (1.0 + jitter * rng.uniform(-1.0, 1.0, n))
    return np.concatenate([[0.0], np.cumsum(dt)])


def test_two_sample_divisor_is_savage_for_equal_intervals():
    assert mechanization.two_sample_divisor(0.01, 0.01) == 12.0
    assert mechanization.two_sample_divisor(0.01, 0.01 * (1 + 1e-12)) == 12.0        # stamp float noise
    assert mechanization.two_sample_divisor(0.01, None) == 12.0
    # a longer current interval weighs the cross product more: h2^2 / (6 h1 (h1 + h2))
    assert mechanization.two_sample_divisor(0.02, 0.01) == pytest.approx(6 * 0.01 * 0.03 / 0.0004, rel=1e-15)


def test_coning_on_uniform_intervals_removes_the_drift():
    """Equal intervals: the two-sample term removes the coning drift (measured:
    none 1.40e-3 rad, two-sample 1.31e-5 rad after 10 s)."""
    t = _time_line(0.0)
    e_none, e_two = _attitude_error_rad(t, "none"), _attitude_error_rad(t, "uneven")
    assert e_none > 1e-3
    assert e_two < e_none / 100.0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_coning_on_jittered_intervals_weighted_beats_equal_weight(seed):
    """Intervals jittered +/-40 %: the weighted term stays near the uniform-rate
    level (tolerance 5e-5 rad after 10 s, ~0.003 deg; measured 1.72-1.77e-5
    over seeds 0-2), the 1/12 weight does ~10x worse (1.62-1.72e-4), rotation
    increments alone drift 1.63-1.65e-3 rad."""
    t = _time_line(0.4, seed)
    e_none = _attitude_error_rad(t, "none")
    e_equal = _attitude_error_rad(t, "equal")
    e_uneven = _attitude_error_rad(t, "uneven")
    print(f"seed {seed}: none {e_none:.3e} rad, 1/12 weight {e_equal:.3e}, weighted {e_uneven:.3e}")
    assert e_uneven < 5e-5
    assert e_uneven < 0.2 * e_equal
    assert e_uneven < e_none / 50.0
