"""Interacting multiple model (IMM) filter, the classical answer to
maneuvering targets (Blom and Bar-Shalom 1988; Li and Jilkov 2005, seed 002
ref. [4]), over the same parametric glide model.

Modes differ in the lateral maneuver they assume: mode j flies eq. 21 with
u_j = [lambda1, (lambda1^2 + a_j^2 + 1)/lambda1, T_chi], i.e. the nominal
vertical lift lambda1 and a lateral lift c_l sin(sigma) = a_j
(``tracker.imm_lateral_c_l``; its direction is the filter's chi state), and a
process noise Q_0 scaled by ``tracker.imm_q_scale[j]``. Markov mode
transitions with probability ``imm_p_stay`` of staying, the rest spread
evenly. Cycle: mixing, mode-matched EKFs (``ekf``), Gaussian likelihoods of
the innovations, mode probabilities, moment-matched output.
"""
from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from hyper_nav_filter.core.target_tracking import ekf
from hyper_nav_filter.core.target_tracking import glide_model as gm


class ImmCarry(NamedTuple):
    x: jnp.ndarray        # (M, 7) mode-conditioned states
    P: jnp.ndarray        # (M, 7, 7)
    mu: jnp.ndarray       # (M,) mode probabilities


def mode_inputs(u_nominal, lateral_c_l) -> np.ndarray:
    """(M, 3) inputs of the modes: lambda2 = (lambda1^2 + a^2 + 1) / lambda1."""
    lam1 = float(u_nominal[0])
    a = np.asarray(lateral_c_l, float)
    return np.stack([np.full_like(a, lam1), (lam1**2 + a**2 + 1.0) / lam1, np.full_like(a, u_nominal[2])], -1)


def transition_matrix(n_modes: int, p_stay: float) -> np.ndarray:
    T = np.full((n_modes, n_modes), (1.0 - p_stay) / (n_modes - 1))
    np.fill_diagonal(T, p_stay)
    return T


def init(x0, P0, n_modes: int) -> ImmCarry:
    return ImmCarry(jnp.broadcast_to(x0, (n_modes,) + x0.shape), jnp.broadcast_to(P0, (n_modes,) + P0.shape),
                    jnp.full((n_modes,), 1.0 / n_modes, dtype=x0.dtype))


def combine(x, P, w):
    """Moment matching of a Gaussian mixture (weights w sum to 1)."""
    xm = jnp.einsum("m,mi->i", w, x)
    d = x - xm
    Pm = jnp.einsum("m,mij->ij", w, P + jnp.einsum("mi,mj->mij", d, d))
    return xm, Pm


def imm_step(model: gm.GlideModel, U, Qs, R, Tm, carry: ImmCarry, z, dt, valid):
    # mixing: mu_{i|j} = T_ij mu_i / c_j
    c = Tm.T @ carry.mu
    w_mix = (Tm * carry.mu[:, None]) / c[None, :]                   # (i, j)
    x0, P0 = jax.vmap(lambda w: combine(carry.x, carry.P, w), in_axes=1)(w_mix)

    def mode(x, P, u, Q):
        x_pred, P_pred, _ = ekf.predict(model, x, P, u, dt, Q)
        K, y, S = ekf.gain(x_pred, P_pred, z, R)
        K = jnp.where(valid, K, 0.0)
        xn, Pn = ekf.update(x_pred, P_pred, K, y, R)
        _, logdet = jnp.linalg.slogdet(2.0 * jnp.pi * S)
        loglik = -0.5 * (ekf.nis(y, S) + logdet)
        return xn, Pn, loglik

    xs, Ps, loglik = jax.vmap(mode)(x0, P0, U, Qs)
    loglik = jnp.where(valid, loglik, 0.0)
    logw = jnp.log(jnp.maximum(c, 1e-30)) + loglik
    mu = jnp.exp(logw - jax.scipy.special.logsumexp(logw))
    mu = jnp.maximum(mu, 1e-6)
    mu = mu / jnp.sum(mu)
    x, P = combine(xs, Ps, mu)
    return ImmCarry(xs, Ps, mu), {"x": x, "P": P, "u": jnp.einsum("m,mi->i", mu, U), "mu": mu}
