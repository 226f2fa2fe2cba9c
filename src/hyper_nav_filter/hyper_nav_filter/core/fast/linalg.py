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


@njit(cache=True, inline="always")
def mm3(A, B):
    """3 x 3 product in scalar code: numba's ``@`` calls BLAS, whose call
    overhead is several times the arithmetic at this size (measured on the
    ENU kernel: mechanization 2.4 -> 1.2 us, body couplings 1.9 -> 1.0 us;
    dense 15 x 15 products stay on BLAS, which beat scalar loops that skip
    F's zero rows, 3.2 vs 6.5 us; the covariance propagation now goes by the
    blocks of F instead, ``predict.propagate_covariance_blocks``)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


@njit(cache=True, inline="always")
def mv3(A, v):
    """A v for a 3 x 3 A (scalar code, as ``mm3``)."""
    return np.array([A[0, 0] * v[0] + A[0, 1] * v[1] + A[0, 2] * v[2],
                     A[1, 0] * v[0] + A[1, 1] * v[1] + A[1, 2] * v[2],
                     A[2, 0] * v[0] + A[2, 1] * v[1] + A[2, 2] * v[2]])


@njit(cache=True, inline="always")
def mm3n(A, B):
    """A B for a 3 x 3 A and a 3 x n B (scalar code, as ``mm3``)."""
    n = B.shape[1]
    out = np.empty((3, n))
    for i in range(3):
        for j in range(n):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


@njit(cache=True)
def rotvec_to_C(phi):
    """Rodrigues, as ``attitude.rotvec_to_C`` (series below 1e-6 rad)."""
    angle2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]
    K = skew(phi)
    KK = mm3(K, K)
    if angle2 < 1e-12:
        a, b = 1.0, 0.5
    else:
        angle = math.sqrt(angle2)
        a, b = math.sin(angle) / angle, (1.0 - math.cos(angle)) / angle2
    C = a * K + b * KK
    for i in range(3):
        C[i, i] += 1.0
    return C


@njit(cache=True)
def orthonormalize(C):
    """C - C (C^T C - I) / 2."""
    E = mm3(C.T, C)
    for i in range(3):
        E[i, i] -= 1.0
    return C - 0.5 * mm3(C, E)


@njit(cache=True)
def inv_small(S):
    """(ok, S^-1) of a small square matrix by Gauss-Jordan elimination with
    partial pivoting; ok False when a pivot is exactly zero (singular).
    Used for innovation covariances (1-12 rows), where numba's
    ``np.linalg.inv`` (LAPACK getrf/getri with workspace allocation and an
    exception on failure) costs more than the arithmetic."""
    n = S.shape[0]
    A = S.copy()
    Inv = np.eye(n)
    for c in range(n):
        p = c
        best = abs(A[c, c])
        for r in range(c + 1, n):
            if abs(A[r, c]) > best:
                best = abs(A[r, c])
                p = r
        if best == 0.0:
            return False, Inv
        if p != c:
            for j in range(n):
                A[c, j], A[p, j] = A[p, j], A[c, j]
                Inv[c, j], Inv[p, j] = Inv[p, j], Inv[c, j]
        d = 1.0 / A[c, c]
        for j in range(n):
            A[c, j] *= d
            Inv[c, j] *= d
        for r in range(n):
            if r != c:
                m = A[r, c]
                if m != 0.0:
                    for j in range(n):
                        A[r, j] -= m * A[c, j]
                        Inv[r, j] -= m * Inv[c, j]
    return True, Inv


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
