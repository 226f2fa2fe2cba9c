"""Receiver autonomous integrity monitoring: fault detection and exclusion
(RAIM/FDE) on weighted least-squares pseudorange residuals.

Detection (global test; e.g. Kaplan and Hegarty, Understanding GPS, 2nd ed.,
section 7.5.2; Teunissen 1990 "Quality control in integrated navigation
systems"): with residuals v = y - H x_hat and weights W = C^-1, the weighted
sum of squares T = v^T W v is chi-square distributed with n - m degrees of
freedom when every measurement is fault-free and its variance is right;
a fault is declared when T exceeds the chi-square quantile of the chosen
false-alarm probability P_fa (:func:`threshold`).

Exclusion (local test, Baarda's w-test): the standardized residual
w_i = v_i / sqrt((Q_v)_ii), Q_v = C - H (H^T W H)^-1 H^T, of each satellite;
the largest |w_i| names the most likely faulty one, which is excluded, the
solution recomputed and the global test repeated, as long as at least one
degree of freedom is left to test the result.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np


@lru_cache(maxsize=1024)
def threshold(dof: int, p_fa: float) -> float:
    """Chi-square quantile: P(T > threshold) = p_fa for dof degrees of freedom
    (cached: scipy's isf costs ~2.7 ms a call, a third of an epoch's solve).
    ``scipy.special.chdtri`` is what ``scipy.stats.chi2.isf`` evaluates (the
    same double for every dof and P_fa); imported here, not with the module:
    ``scipy.stats`` alone took half a second of the ``spp`` command's start."""
    from scipy.special import chdtri
    return float(chdtri(dof, p_fa))


def global_statistic(v, var) -> float:
    """T = sum v_i^2 / var_i (diagonal covariance)."""
    v = np.asarray(v, float)
    return float(np.sum(v * v / np.asarray(var, float)))


def standardized_residuals(H, v, var) -> np.ndarray:
    """Baarda w-test statistics w_i = v_i / sqrt((Q_v)_ii) (0 where the
    redundancy of a measurement is nil)."""
    H = np.asarray(H, float)
    var = np.asarray(var, float)
    W = 1.0 / var
    N = H.T @ (H * W[:, None])
    Ninv = np.linalg.pinv(N)
    qv = var - np.einsum("ij,jk,ik->i", H, Ninv, H)
    qv = np.where(qv > 1e-12 * var, qv, np.inf)
    return np.asarray(v, float) / np.sqrt(qv)
