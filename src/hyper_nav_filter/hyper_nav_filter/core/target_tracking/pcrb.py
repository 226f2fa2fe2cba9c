"""Posterior Cramer-Rao bound of the tracking problem with the true maneuver
known (Tichavsky, Muravchik and Nehorai 1998).

With the maneuver known, the inputs u_k (lambda1, lambda2 and the signed
lateral lift from the flown c_l and bank angle) are given and the state is
the six kinematic quantities [h, theta, phi, v, gamma, psi]; the only
randomness left is the initial state (covariance P0) and the radar noise R.
For additive Gaussian noise and the linear measurement z = H x the
information recursion is

    J_{k+1} = (F_k J_k^-1 F_k^T + Q)^-1 + H^T R^-1 H

with F_k the Jacobian of the discrete model (eq. 21, RK4) at the true
state; Q = 0 (known maneuver, exact model) gives the bound no filter passes.
Jacobians are evaluated along the true trajectory (the usual approximation
of the expectation in the PCRB for a single reference track). The bound is
returned as the RMS over time of sqrt(diag J_k^-1) per state, in float64.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from hyper_nav_filter.core.target_tracking import glide_model as gm

N_KIN = 6


def _chi_for_sign(sign, k_chi):
    return np.arctanh(0.999 * np.clip(sign, -1.0, 1.0)) / k_chi


def jacobians(model: gm.GlideModel, x_true_phys, u_true, lateral_sign, dt: float) -> np.ndarray:
    """(N-1, 6, 6) Jacobians of the 6-state discrete model along the truth;
    ``lateral_sign`` (N,) = sign of the bank angle (the maneuver's direction)."""
    xs = gm.to_scaled(np.asarray(x_true_phys, float))
    xs[:, 6] = _chi_for_sign(np.asarray(lateral_sign, float), model.k_chi)

    def f6(x6, chi, u):
        return gm.propagate(model, jnp.concatenate([x6, chi[None]]), u, dt)[:N_KIN]

    jac = jax.jit(jax.vmap(jax.jacfwd(f6), in_axes=(0, 0, 0)))
    return np.asarray(jac(jnp.asarray(xs[:-1, :N_KIN], jnp.float32), jnp.asarray(xs[:-1, 6], jnp.float32),
                          jnp.asarray(u_true[:-1], jnp.float32)), float)


def bound(F: np.ndarray, P0: np.ndarray, R: np.ndarray, Q: np.ndarray | None = None) -> np.ndarray:
    """(N, 6, 6) bound covariances (scaled units): J_0^-1 = P0 updated with the
    first measurement, then the recursion above."""
    H = np.eye(gm.N_Z, N_KIN)
    HRH = H.T @ np.linalg.inv(R) @ H
    Q = np.zeros((N_KIN, N_KIN)) if Q is None else Q[:N_KIN, :N_KIN]
    out = np.empty((len(F) + 1, N_KIN, N_KIN))
    J = np.linalg.inv(P0[:N_KIN, :N_KIN]) + HRH
    out[0] = np.linalg.inv(J)
    for k, Fk in enumerate(F):
        Pp = Fk @ out[k] @ Fk.T + Q
        J = np.linalg.inv(0.5 * (Pp + Pp.T)) + HRH
        Pk = np.linalg.inv(J)
        out[k + 1] = 0.5 * (Pk + Pk.T)
    return out


def rms_bound(P_bound_scaled: np.ndarray) -> np.ndarray:
    """RMS over time of the bound's standard deviations, physical units (6,)."""
    var = np.diagonal(P_bound_scaled, axis1=1, axis2=2) * gm.STATE_SCALE[:N_KIN] ** 2
    return np.sqrt(np.mean(var, axis=0))
