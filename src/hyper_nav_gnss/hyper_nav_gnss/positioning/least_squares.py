"""Weighted least squares of GNSS positioning: the one normal-equation solve of the project.

Used by the simulated receiver's PVT (:mod:`.pvt`: position/clock and velocity/drift) and by single-point
positioning on real receiver files (:mod:`.spp`: per epoch, the batched epochs and the Doppler velocity).
The DOPs are :mod:`.dop`; the residual tests of RAIM are :mod:`.raim`.

Linearised model at the current estimate x (one Gauss-Newton step for a non-linear model, the whole solution
for a linear one; RTKLIB manual 2.4.2 App. E.6.1, Groves 2nd ed. section 9.4.2 (the weighted form of the
single-epoch solution), Kaplan & Hegarty 2nd ed. 2.4.2)::

    v = y - h(x) = H dx + e,      e ~ N(0, W^-1),  W = diag(w),  w_j = 1 / sigma_j^2

normal equations and step::

    N  = H^T W H
    dx = N^-1 H^T W v             (solved by LU, never by forming N^-1)

covariance of the estimate (a-priori weights, unit-weight variance 1; a caller that scales by the
unit-weight variance v^T W v / (n - m) does so itself)::

    P = N^-1

and for a linear model y = H x + e the residuals at the solution are v = y - H x.

Clock columns: a receiver that tracks several systems has one clock bias b (of the reference system, the
first of the ordered system list) on every row and one inter-system bias b_s on the rows of each further
system s (RTKLIB's per-system clock terms in the per-epoch form; Groves 2nd ed. 9.4.2 "inter-constellation
timing bias")::

    rho_j = |r_sat_j - r| + b + b_sys(j),   H_clk[j] = [1, [sys(j) == s for s in systems[1:]]]

A singular N (a geometry that does not fix the unknowns: too few independent lines of sight, a clock
column without rows) gives None from every function here (``numpy.linalg.LinAlgError`` is not raised);
the caller decides what that means for its epoch.

Arithmetic: N = H^T (H * w) and H^T (w * v), in that order (what SPP and RAIM computed before this module:
SPP's per-epoch solutions are unchanged to the bit; the PVT's, which multiplied (H^T * w) @ H, moved in the
last digits only).
"""
from __future__ import annotations

import numpy as np


def clock_columns_from_slots(slot: np.ndarray, n_systems: int) -> np.ndarray:
    """Clock design columns from each row's system slot (0 = the reference system, k = the k-th further
    system, a slot < 0 or >= ``n_systems`` gives no ISB entry). ``slot`` may have leading batch dimensions
    (epochs x satellites); returns ``slot.shape + (n_systems,)``: column 0 ones, column k the rows of slot k."""
    slot = np.asarray(slot)
    cols = (slot[..., None] == np.arange(n_systems)).astype(float)
    if n_systems:
        cols[..., 0] = 1.0
    return cols


def clock_columns(row_systems, systems) -> np.ndarray:
    """(n, len(systems)) clock columns of rows whose systems are ``row_systems`` (e.g. "G", "C"), for the
    ordered system list ``systems`` (its first the reference): the reference clock on every row, one
    inter-system-bias column per further system."""
    index = {s: k for k, s in enumerate(systems)}
    return clock_columns_from_slots(np.array([index.get(s, -1) for s in row_systems], int), len(systems))


def normal_matrix(H: np.ndarray, w: np.ndarray) -> np.ndarray:
    """N = H^T W H of rows ``H`` (..., n, m) and weights ``w`` (..., n) (leading batch dimensions allowed)."""
    return np.swapaxes(H, -1, -2) @ (H * w[..., None])


def normal_equations(H: np.ndarray, v: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, H^T W v) of rows ``H`` (..., n, m), misclosures ``v`` (..., n), weights ``w`` (..., n)."""
    Ht = np.swapaxes(H, -1, -2)
    rhs = Ht @ (w * v) if H.ndim == 2 else (Ht @ (w * v)[..., None])[..., 0]
    return normal_matrix(H, w), rhs


def solve_step(H: np.ndarray, v: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """One weighted least-squares step: (dx, N) with dx = N^-1 H^T W v, N = H^T W H; None when N is singular."""
    N, rhs = normal_equations(H, v, w)
    try:
        return np.linalg.solve(N, rhs), N
    except np.linalg.LinAlgError:
        return None


def covariance(H: np.ndarray, w: np.ndarray) -> np.ndarray | None:
    """P = (H^T W H)^-1, the covariance of the estimate under the a-priori weights; None when singular."""
    try:
        return np.linalg.inv(normal_matrix(H, w))
    except np.linalg.LinAlgError:
        return None


def solve_linear(H: np.ndarray, y: np.ndarray, w: np.ndarray):
    """Weighted least squares of a linear model y = H x + e: (x, P = N^-1, residuals y - H x); None when
    N is singular."""
    step = solve_step(H, y, w)
    if step is None:
        return None
    x, N = step
    try:
        P = np.linalg.inv(N)
    except np.linalg.LinAlgError:
        return None
    return x, P, y - H @ x
