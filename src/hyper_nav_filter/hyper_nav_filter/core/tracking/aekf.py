"""Adaptive EKF: innovation-based process-noise estimation.

Which and why. Sage-Husa (the adaptive filter of seed 002's ref. [5]) estimates
Q and R together from the innovations with a fading memory; estimating both
from the same three innovations is poorly determined, and its Q update
subtracts terms (P - F P F^T) that turn Q indefinite during exactly the
maneuvers it should follow, which is why ref. [5] needs extra judgement
rules. Here R is known (the radar's datasheet noise, seed 002 section 3.2) and
the uncertainty is the maneuver, i.e. the process noise, so only Q is adapted,
with the innovation-based covariance-matching update of Akhlaghi, Zhou and
Huang (2017, "Adaptive adjustment of noise covariance in Kalman filter for
dynamic state estimation")::

    Q_a,k = alpha Q_a,k-1 + (1 - alpha) K_k d_k d_k^T K_k^T      (d_k: innovation)
    Q_k   = Q_0 + Q_a,k

a sum of positive semi-definite terms, so Q_k stays positive definite by
construction; Q_0 (the EKF's Q) is the floor, alpha the forgetting factor
(``tracker.aekf_forgetting``). K d d^T K^T is the covariance of the state
correction over one radar interval, so Q_a is used per interval (not per s).
"""
from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp

from . import ekf
from . import glide_model as gm


class AekfCarry(NamedTuple):
    x: jnp.ndarray
    P: jnp.ndarray
    Qa: jnp.ndarray        # adapted part of the process noise (per interval, scaled units)


def init(x0, P0) -> AekfCarry:
    return AekfCarry(x0, P0, jnp.zeros_like(P0))


def aekf_step(model: gm.GlideModel, u, Q0, R, alpha, carry: AekfCarry, z, dt, valid):
    x_pred, P_pred, _ = ekf.predict(model, carry.x, carry.P, u, dt, Q0)
    P_pred = P_pred + carry.Qa
    K, y, S = ekf.gain(x_pred, P_pred, z, R)
    K = jnp.where(valid, K, 0.0)
    x, P = ekf.update(x_pred, P_pred, K, y, R)
    dx = K @ y
    Qa = jnp.where(valid, alpha * carry.Qa + (1.0 - alpha) * jnp.outer(dx, dx), carry.Qa)
    return AekfCarry(x, P, Qa), {"x": x, "P": P, "u": u, "nis": jnp.where(valid, ekf.nis(y, S), 0.0)}
