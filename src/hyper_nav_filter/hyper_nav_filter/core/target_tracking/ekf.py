"""Extended Kalman filter on the parametric glide model (seed 002 eqs. 23-27).

Pure functions of arrays in the scaled state units of ``glide_model``; the
filters built on them (adaptive EKF, IMM, L-EKF) reuse ``predict``, ``gain``
and ``update``. The covariance update is Joseph's form, valid for any gain:
the L-EKF updates with a modified gain K~ (section 2.4 step 5), for which the
printed (I - K~ H) P is not the covariance of the estimate.
"""
from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp

from hyper_nav_filter.core.target_tracking import glide_model as gm


class EkfCarry(NamedTuple):
    x: jnp.ndarray          # (7,) scaled state
    P: jnp.ndarray          # (7, 7) scaled covariance


def predict(model: gm.GlideModel, x, P, u, dt, Q):
    """Eqs. 23-24: x- = f(x, u), P- = F P F^T + Q dt (Q per second, scaled units)."""
    x_pred, F = gm.propagate_with_jacobian(model, x, u, dt)
    P_pred = F @ P @ F.T + Q * dt
    return x_pred, 0.5 * (P_pred + P_pred.T), F


def gain(x_pred, P_pred, z, R):
    """Eqs. 25-27: innovation y = z - h(x-), S = H P- H^T + R, K = P- H^T S^-1."""
    y = gm.wrap_innovation(z - gm.measure(x_pred))
    S = P_pred[: gm.N_Z, : gm.N_Z] + R
    S = 0.5 * (S + S.T)
    K = P_pred[:, : gm.N_Z] @ inv3(S)                    # P- H^T S^-1
    return K, y, S


def inv3(S):
    """Inverse of a 3x3 matrix by its adjugate (compiles in a fraction of the
    time of an LU solve; S is well conditioned: it contains R)."""
    a, b, c = S[0], S[1], S[2]
    adj = jnp.stack([jnp.cross(b, c), jnp.cross(c, a), jnp.cross(a, b)], axis=1)
    return adj / jnp.dot(a, jnp.cross(b, c))


def update(x_pred, P_pred, K, y, R):
    """x = x- + K y, P = (I - K H) P- (I - K H)^T + K R K^T (Joseph)."""
    IKH = jnp.eye(gm.N_X, dtype=P_pred.dtype).at[:, : gm.N_Z].add(-K)
    P = IKH @ P_pred @ IKH.T + K @ R @ K.T
    return x_pred + K @ y, 0.5 * (P + P.T)


def nis(y, S):
    """Normalized innovation squared y^T S^-1 y."""
    return y @ inv3(S) @ y


def ekf_step(model: gm.GlideModel, u, Q, R, carry: EkfCarry, z, dt, valid):
    """One radar epoch; ``valid`` False = predict only (no measurement)."""
    x_pred, P_pred, _ = predict(model, carry.x, carry.P, u, dt, Q)
    K, y, S = gain(x_pred, P_pred, z, R)
    K = jnp.where(valid, K, 0.0)
    x, P = update(x_pred, P_pred, K, y, R)
    return EkfCarry(x, P), {"x": x, "P": P, "u": u, "nis": jnp.where(valid, nis(y, S), 0.0)}
