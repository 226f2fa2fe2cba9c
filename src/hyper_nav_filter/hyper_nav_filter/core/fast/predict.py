"""The frame-independent parts of one compiled predict step: IMU error
correction from the blocks' values, F and G from the frame's 9 x 9 core and
the blocks' declared couplings and noises (``core.system_model`` as data),
Phi, Q and the covariance propagation (``system_model.discretize``)."""
from __future__ import annotations

import numpy as np
from numba import njit

from .linalg import expm_taylor, mm3, skew


@njit(cache=True)
def corrected(dth, dv, dt, vals, gb, ab, sg, sa):
    """``ErrorStateKF.corrected``: biases (start indices gb, ab into vals)
    removed, then the scale factors (sg, sa) divided out."""
    th = dth.copy()
    v = dv.copy()
    for i in gb:
        th = th - vals[i:i + 3] * dt
    for i in ab:
        v = v - vals[i:i + 3] * dt
    for i in sg:
        th = th / (1.0 + vals[i:i + 3])
    for i in sa:
        v = v / (1.0 + vals[i:i + 3])
    return th, v


@njit(cache=True)
def corrected_pair(dth, dv, dt, pdth, pdt, has_prev, vals, gb, ab, sg, sa):
    """The IMU pre-processing's inputs: this interval's corrected increments
    and the previous interval's corrected mean rate (zeros at the first step),
    both with the current values (``ErrorStateKF._predict_fast``)."""
    th, v = corrected(dth, dv, dt, vals, gb, ab, sg, sa)
    if has_prev:
        th_p, _ = corrected(pdth, dv, pdt, vals, gb, ab, sg, sa)
        return th, v, th_p / pdt
    return th, v, np.zeros(3)


@njit(cache=True)
def _basis(k, w, f, wdot):
    """The k-th body-coupling basis of ``system_model``: I, diag(w), diag(f),
    [w x], [wdot x], [w x]^2."""
    if k == 0:
        return np.eye(3)
    if k == 1:
        return np.diag(w)
    if k == 2:
        return np.diag(f)
    if k == 3:
        return skew(w)
    if k == 4:
        return skew(wdot)
    W = skew(w)
    return mm3(W, W)


@njit(cache=True, inline="always")
def _basis_into(k, w, f, wdot, out):
    """``_basis`` into a 3 x 3 work array (the same entries)."""
    if k == 0 or k == 1 or k == 2:
        for i in range(3):
            for j in range(3):
                out[i, j] = 0.0
        for i in range(3):
            out[i, i] = 1.0 if k == 0 else (w[i] if k == 1 else f[i])
    elif k == 3 or k == 4:
        v = w if k == 3 else wdot
        out[0, 0], out[0, 1], out[0, 2] = 0.0, -v[2], v[1]
        out[1, 0], out[1, 1], out[1, 2] = v[2], 0.0, -v[0]
        out[2, 0], out[2, 1], out[2, 2] = -v[1], v[0], 0.0
    else:
        W = skew(w)
        out[:, :] = mm3(W, W)


@njit(cache=True)
def couple(F, G, C, w, f, wdot, Katt, Kvel, used_att, used_vel, GattM, GvelM):
    """Add the blocks' body couplings C K(w, f, wdot) to the attitude and
    velocity rows of F and the body noises C M to the rows of G (only the
    bases some block uses are formed; the sums in the order of ``mm3n``,
    into work arrays)."""
    n = F.shape[0]
    bas = np.empty((3, 3))
    B = np.empty((3, n))
    for rows in (0, 3):
        K = Katt if rows == 0 else Kvel
        used = used_att if rows == 0 else used_vel
        B[:, :] = 0.0
        any_term = False
        for k in range(6):
            if used[k]:
                _basis_into(k, w, f, wdot, bas)
                Kk = K[k]
                for i in range(3):
                    for j in range(n):
                        B[i, j] += bas[i, 0] * Kk[0, j] + bas[i, 1] * Kk[1, j] + bas[i, 2] * Kk[2, j]
                any_term = True
        if any_term:
            for i in range(3):
                for j in range(n):
                    F[rows + i, j] += C[i, 0] * B[0, j] + C[i, 1] * B[1, j] + C[i, 2] * B[2, j]
    m = G.shape[1]
    for i in range(3):
        for j in range(m):
            G[i, j] += C[i, 0] * GattM[0, j] + C[i, 1] * GattM[1, j] + C[i, 2] * GattM[2, j]
            G[3 + i, j] += C[i, 0] * GvelM[0, j] + C[i, 1] * GvelM[1, j] + C[i, 2] * GvelM[2, j]


NAV = 9            # att/vel/pos rows of the error state: the blocks' rows never depend on them


@njit(cache=True)
def _f22_diagonal(F):
    """True when the blocks' part of F (rows and columns NAV:) is diagonal
    (biases and scale factors: Gauss-Markov or random constants; a clock or a
    lever-arm block is not) and the blocks' rows do not depend on att/vel/pos."""
    n = F.shape[0]
    for i in range(NAV, n):
        for j in range(n):
            if i != j and F[i, j] != 0.0:
                return False
    return True


@njit(cache=True)
def propagate_covariance(F, G, qc, P, dt, exact):
    """``propagate_covariance_dense``, by the blocks of F where they allow
    (``propagate_covariance_blocks``: the same second-order transition, the
    same P', about 5x fewer operations); an exact transition (``exact``) or
    non-diagonal block dynamics (a clock, lever-arm modes) go dense."""
    if exact or F.shape[0] <= NAV or not _f22_diagonal(F):
        return propagate_covariance_dense(F, G, qc, P, dt, exact)
    return propagate_covariance_blocks(F, G, qc, P, dt)


@njit(cache=True)
def propagate_covariance_blocks(F, G, qc, P, dt):
    """``propagate_covariance_dense`` (not exact) by the structure of the
    error-state matrix: F = [[F11, F12], [0, D]] with F11 the 9 x 9 att/vel/pos
    core, F12 the blocks' couplings into it and D diagonal (the blocks'
    self-dynamics; the blocks' rows never depend on att/vel/pos). Then

        Phi = I + F dt + (F dt)^2 / 2 = [[A, B], [0, E]],  A = I + F11 dt + (F11 dt)^2 / 2,
        B = F12 dt + (F11 F12 + F12 D) dt^2 / 2,  E = I + D dt + (D dt)^2 / 2 (diagonal),

    and P' = Phi (P + Qh) Phi^T + Qh is formed block by block: with M = P + Qh,
    P'11 = (A M11 + B M21) A^T + (A M12 + B M22) B^T, P'12 = (A M12 + B M22) E,
    P'22 = E M22 E, each computed once (the upper triangle, mirrored). Qh =
    G Qc G^T dt / 2 sums each noise column's outer product over its non-zero
    rows. Same transition and formula as the dense form, ~6,000 instead of
    ~28,000 multiply-adds for 21 states; the two agree to rounding (measured:
    ``test_fast_path.test_covariance_blocks_match_dense``). Returns (P', Phi)."""
    n = F.shape[0]
    k = n - NAV
    h = 0.5 * dt * dt
    # Phi by blocks (products in axpy order, innermost loop over columns: vectorised without reassociation)
    Phi = np.zeros((n, n))
    S = np.zeros((NAV, n))                  # F11 [F11 F12]
    for i in range(NAV):
        for l in range(NAV):
            a = F[i, l]
            if a != 0.0:
                for j in range(n):
                    S[i, j] += a * F[l, j]
    e = np.empty(k)
    for j in range(k):
        d = F[NAV + j, NAV + j]
        e[j] = 1.0 + d * dt + h * d * d
        for i in range(NAV):
            S[i, NAV + j] += F[i, NAV + j] * d
        Phi[NAV + j, NAV + j] = e[j]
    for i in range(NAV):
        for j in range(n):
            Phi[i, j] = F[i, j] * dt + h * S[i, j]
        Phi[i, i] += 1.0
    # Qh = G Qc G^T dt / 2 over each column's non-zero rows
    m = G.shape[1]
    Qh = np.zeros((n, n))
    rows = np.empty(n, np.int64)
    for c in range(m):
        q = qc[c] * 0.5 * dt
        if q == 0.0:
            continue
        nr = 0
        for r in range(n):
            if G[r, c] != 0.0:
                rows[nr] = r
                nr += 1
        for a in range(nr):                 # each pair once: Qh exactly symmetric
            ra = rows[a]
            ga = G[ra, c] * q
            Qh[ra, ra] += ga * G[ra, c]
            for b in range(a + 1, nr):
                rb = rows[b]
                v = ga * G[rb, c]
                Qh[ra, rb] += v
                Qh[rb, ra] += v
    M = P + Qh
    # T = [A B] M (the first NAV rows of Phi M)
    T = np.zeros((NAV, n))
    for i in range(NAV):
        for l in range(n):
            a = Phi[i, l]
            if a != 0.0:
                for j in range(n):
                    T[i, j] += a * M[l, j]
    # P'11 = T [A B]^T: U = T Phi^T by rows of Phi (columns of the product), axpy over i
    P1 = np.empty((n, n))
    U = np.zeros((NAV, NAV))
    for jj in range(NAV):
        for l in range(n):
            a = Phi[jj, l]
            if a != 0.0:
                for i in range(NAV):
                    U[i, jj] += T[i, l] * a
    for i in range(NAV):
        for j in range(i, NAV):             # each symmetric pair once: P' exactly symmetric
            v = 0.5 * (U[i, j] + U[j, i]) + Qh[i, j]
            P1[i, j] = v
            P1[j, i] = v
        for j in range(k):
            v = T[i, NAV + j] * e[j] + Qh[i, NAV + j]
            P1[i, NAV + j] = v
            P1[NAV + j, i] = v
    for i in range(k):
        for j in range(i, k):
            v = e[i] * (0.5 * (M[NAV + i, NAV + j] + M[NAV + j, NAV + i])) * e[j] + Qh[NAV + i, NAV + j]
            P1[NAV + i, NAV + j] = v
            P1[NAV + j, NAV + i] = v
    return P1, Phi


@njit(cache=True)
def propagate_covariance_dense(F, G, qc, P, dt, exact):
    """Phi = I + F dt + (F dt)^2 / 2 (or expm) and
    P' = Phi (P + Qh) Phi^T + Qh with Qh = G Qc G^T dt / 2, i.e. the
    trapezoidal Q = (Phi GQG Phi^T + GQG) dt / 2 of ``system_model.discretize``
    added to Phi P Phi^T with two products fewer. Returns (P', Phi)."""
    n = F.shape[0]
    Fdt = F * dt
    if exact:
        Phi = expm_taylor(Fdt)
    else:
        Phi = np.eye(n) + Fdt + 0.5 * (Fdt @ Fdt)
    Gq = G * qc
    Qh = (Gq @ G.T) * (0.5 * dt)
    P1 = Phi @ (P + Qh) @ Phi.T + Qh
    return 0.5 * (P1 + P1.T), Phi


@njit(cache=True, inline="always")
def _corrected_into(src, dt, vals, gb, ab, sg, sa, is_gyro, out):
    """``corrected`` of one vector (gyro: biases gb, scales sg; accel: ab, sa)
    into ``out``, element by element in the same order of operations."""
    for a in range(3):
        out[a] = src[a]
    if is_gyro:
        for i in gb:
            for a in range(3):
                out[a] = out[a] - vals[i + a] * dt
        for i in sg:
            for a in range(3):
                out[a] = out[a] / (1.0 + vals[i + a])
    else:
        for i in ab:
            for a in range(3):
                out[a] = out[a] - vals[i + a] * dt
        for i in sa:
            for a in range(3):
                out[a] = out[a] / (1.0 + vals[i + a])


@njit(cache=True)
def imu_terms(dth, dv, dt, pdth, pdv, pdt, has_prev, vals, gb, ab, sg, sa):
    """The corrected increments of this and the previous interval (zeros at
    the first step), the body rate, specific force and angular acceleration
    of this interval (zero acceleration at the first step). (``corrected``
    element by element: the same numbers, a seventh of the allocations.)"""
    th, v = np.empty(3), np.empty(3)
    th_p, v_p = np.zeros(3), np.zeros(3)
    w, f, wdot = np.empty(3), np.empty(3), np.zeros(3)
    _corrected_into(dth, dt, vals, gb, ab, sg, sa, True, th)
    _corrected_into(dv, dt, vals, gb, ab, sg, sa, False, v)
    for a in range(3):
        w[a] = th[a] / dt
        f[a] = v[a] / dt
    if has_prev:
        _corrected_into(pdth, pdt, vals, gb, ab, sg, sa, True, th_p)
        _corrected_into(pdv, pdt, vals, gb, ab, sg, sa, False, v_p)
        for a in range(3):
            wdot[a] = (th[a] / dt - th_p[a] / pdt) / dt
    return th, v, th_p, v_p, w, f, wdot
