"""The gated Joseph-form measurement update in compiled form (the same
algebra as ``ErrorStateKF.update``'s numpy path, which stays the reference)."""
from __future__ import annotations

import numpy as np
from numba import njit

from .linalg import inv_small


@njit(cache=True)
def joseph_update(P, H, R, r, threshold):
    """(status, nis, dx, P'): status 0 accepted, 1 gated (NIS > threshold or
    not finite), 2 singular innovation covariance (P unchanged)."""
    S = H @ P @ H.T + R
    S = 0.5 * (S + S.T)
    PHt = P @ H.T
    ok, Si = inv_small(S)
    if not ok:
        return 2, np.inf, np.zeros(P.shape[0]), P
    nis = r @ (Si @ r)
    if not np.isfinite(nis) or nis > threshold:
        return 1, nis, np.zeros(P.shape[0]), P
    K = PHt @ Si
    dx = K @ r
    I_KH = np.eye(P.shape[0]) - K @ H
    P1 = I_KH @ P @ I_KH.T + K @ R @ K.T
    return 0, nis, dx, 0.5 * (P1 + P1.T)
