"""Small fixed-size linear algebra for the kernels (numba, scalar code)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@njit(cache=True, inline="always")
def skew(v):
    S = np.zeros((3, 3))
    S[0, 1], S[0, 2] = -v[2], v[1]
    S[1, 0], S[1, 2] = v[2], -v[0]
    S[2, 0], S[2, 1] = -v[1], v[0]
    return S


@njit(cache=True)
def rotvec_to_C(phi):
    """Rodrigues, as ``attitude.rotvec_to_C`` (series below 1e-6 rad)."""
    angle2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]
    K = skew(phi)
    KK = K @ K
    if angle2 < 1e-12:
        return np.eye(3) + K + 0.5 * KK
    angle = math.sqrt(angle2)
    return np.eye(3) + (math.sin(angle) / angle) * K + ((1.0 - math.cos(angle)) / angle2) * KK


@njit(cache=True)
def orthonormalize(C):
    return C - 0.5 * C @ (C.T @ C - np.eye(3))


@njit(cache=True)
def expm_taylor(A):
    """Scaling and squaring of the 4th-order Taylor series, as
    ``system_model.expm_taylor`` (order 4, tol 0.25)."""
    n = A.shape[0]
    nrm = 0.0
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += abs(A[i, j])
        nrm = max(nrm, s)
    s = 0
    if nrm > 0:
        s = max(0, int(math.ceil(math.log2(nrm / 0.25))))
    B = A / 2.0**s
    P = np.eye(n)
    term = np.eye(n)
    for k in range(1, 5):
        term = term @ B / k
        P = P + term
    for _ in range(s):
        P = P @ P
    return P
