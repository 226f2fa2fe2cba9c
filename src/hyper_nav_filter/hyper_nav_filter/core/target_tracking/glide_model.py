"""Parametric glide model of a hypersonic target (seed 002 eqs. 1-22), in JAX.

State ``x = [h, theta, phi, v, gamma, psi, chi]`` (``STATE_NAMES``): altitude
above the model sphere (m; the paper's r = R_e + h), longitude and latitude
(rad), speed (m/s), flight-path angle (rad), heading (rad, clockwise from
north) and the lateral-direction state chi. Input ``u = [lambda1, lambda2,
T_chi]`` (eq. 14, 17, 20): lambda1 = c_l cos(sigma), lambda2 = (c_l^2 + 1) /
(c_l cos(sigma)), T_chi the time constant (s) of the lateral-direction model.
Measurement ``z = [h, theta, phi]`` (eq. 22), the early-warning radar's.

Equations (eq. 21, with three typos of the printed equation corrected; each
follows from eqs. 5, 6, 8, 9, 14, 17 of the same paper)::

    h'     = v sin(gamma)
    theta' = v cos(gamma) sin(psi) / (r cos(phi))
    phi'   = v cos(gamma) cos(psi) / r
    v'     = -rho v^2 S C_D* lambda1 lambda2 / (4 m) - g sin(gamma)
    gamma' = rho v S C_L* lambda1 / (2 m) + (v/r - g/v) cos(gamma)
    psi'   = rho v S C_L* tanh(k_chi chi) sqrt(lambda1 lambda2 - 1 - lambda1^2) / (2 m cos(gamma))
             + v/r cos(gamma) sin(psi) tan(phi)
    chi'   = -chi / T_chi

* gamma': the printed eq. 21 has lambda2; the vertical lift is c_l cos(sigma) = lambda1 (eq. 5, 14).
* psi': the printed root is sqrt(lambda1 lambda2 - lambda2^2 - 1); c_l sin(sigma) =
  sqrt(c_l^2 - (c_l cos sigma)^2) = sqrt(lambda1 lambda2 - 1 - lambda1^2).
* psi' curvature term: + with psi clockwise from north (Clairaut: sin(psi) cos(phi)
  is constant on a great circle); the printed minus is Vinh's convention with psi from east.

Our choices where the paper gives none (all from the scenario's ``tracker:`` block):
gravity g = g0 (R_e / r)^2; rho = rho0 exp(-beta h) fitted to US76 over
20-60 km (the simulator flies US76 over a rotating WGS-84 Earth: the filter's
world is deliberately not the simulator's, STYLE 16); k_chi finite (the paper's
"very large" k_chi makes chi unobservable through the EKF Jacobian, tanh' = 0
away from chi = 0). The root is smoothed, sqrt(max(a, 0) + eps^2) - eps, so
that gradients stay finite at a = 0 (no lateral maneuver).

Filters work in the scaled state ``x / STATE_SCALE`` (km, mrad, 100 m/s,
mrad, 10 mrad): covariances then span a few decades only and float32 (JAX's
default) is accurate (position resolution ~0.3 m at 1 rad of longitude).
"""
from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

STATE_NAMES = ("h", "theta", "phi", "v", "gamma", "psi", "chi")
INPUT_NAMES = ("lambda1", "lambda2", "T_chi")
MEAS_NAMES = ("h", "theta", "phi")
N_X, N_U, N_Z = 7, 3, 3
# physical units per scaled unit: m, rad, rad, m/s, rad, rad, 1
STATE_SCALE = np.array([1.0e3, 1.0e-3, 1.0e-3, 100.0, 1.0e-3, 1.0e-2, 1.0])
H_MEAS = np.eye(N_Z, N_X)           # z = H x (eq. 22), in scaled units as well
_ROOT_EPS = 1.0e-2


@dataclass(frozen=True)
class GlideModel:
    """Constants of eq. 21 (SI). ``cl_star``/``cd_star`` from the Mach-independent
    polar C_D = C_D0 + K C_L^2 (seed 002 eqs. 7-9)."""
    earth_radius_m: float = 6378135.0          # the paper's R_e
    g0_mps2: float = 9.80665
    rho0_kgpm3: float = 1.3198
    beta_per_m: float = 1.4238e-4
    mass_kg: float = 907.0
    s_ref_m2: float = 0.4839
    cd0: float = 0.045
    k_induced: float = 0.62
    k_chi: float = 1.0
    substeps: int = 1                           # RK4 steps per propagation interval

    @property
    def cl_star(self) -> float:
        return float(np.sqrt(self.cd0 / self.k_induced))

    @property
    def cd_star(self) -> float:
        return 2.0 * self.cd0


def derivative(model: GlideModel, x, u):
    """dx/dt of eq. 21 in physical units; x (7,), u (3,)."""
    h, theta, phi, v, gam, psi, chi = (x[i] for i in range(N_X))
    lam1, lam2, t_chi = u[0], u[1], u[2]
    r = model.earth_radius_m + h
    g = model.g0_mps2 * (model.earth_radius_m / r) ** 2
    rho = model.rho0_kgpm3 * jnp.exp(-model.beta_per_m * h)
    k_lift = rho * v * model.s_ref_m2 * model.cl_star / (2.0 * model.mass_kg)
    cg, sg = jnp.cos(gam), jnp.sin(gam)
    lat_arg = lam1 * lam2 - 1.0 - lam1 * lam1            # (c_l sin sigma)^2
    c_lat = jnp.sqrt(jnp.maximum(lat_arg, 0.0) + _ROOT_EPS**2) - _ROOT_EPS
    return jnp.stack([
        v * sg,
        v * cg * jnp.sin(psi) / (r * jnp.cos(phi)),
        v * cg * jnp.cos(psi) / r,
        -rho * v * v * model.s_ref_m2 * model.cd_star * lam1 * lam2 / (4.0 * model.mass_kg) - g * sg,
        k_lift * lam1 + (v / r - g / v) * cg,
        k_lift * jnp.tanh(model.k_chi * chi) * c_lat / cg + v / r * cg * jnp.sin(psi) * jnp.tan(phi),
        -chi / t_chi,
    ])


def propagate_phys(model: GlideModel, x, u, dt):
    """x(t + dt) by ``model.substeps`` classical RK4 steps (physical units)."""
    h = dt / model.substeps

    def rk4(_, y):
        k1 = derivative(model, y, u)
        k2 = derivative(model, y + 0.5 * h * k1, u)
        k3 = derivative(model, y + 0.5 * h * k2, u)
        k4 = derivative(model, y + h * k3, u)
        return y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    for i in range(model.substeps):         # unrolled (a handful): cheaper to compile than a loop
        x = rk4(i, x)
    return x


def propagate(model: GlideModel, xs, u, dt):
    """Discrete transition f(x, u) of eqs. 23 in scaled units."""
    scale = jnp.asarray(STATE_SCALE, xs.dtype)
    return propagate_phys(model, xs * scale, u, dt) / scale


def jacobian(model: GlideModel, x, u):
    """A = d(dx/dt)/dx of eq. 21 (physical units), written out: the same as
    ``jax.jacfwd(derivative)`` (tested) at a fraction of the compile time."""
    h, theta, phi, v, gam, psi, chi = (x[i] for i in range(N_X))
    lam1, lam2, t_chi = u[0], u[1], u[2]
    beta = model.beta_per_m
    r = model.earth_radius_m + h
    g = model.g0_mps2 * (model.earth_radius_m / r) ** 2
    rho = model.rho0_kgpm3 * jnp.exp(-beta * h)
    k_lift = rho * v * model.s_ref_m2 * model.cl_star / (2.0 * model.mass_kg)
    drag = rho * v * v * model.s_ref_m2 * model.cd_star * lam1 * lam2 / (4.0 * model.mass_kg)
    cg, sg, cp, sp = jnp.cos(gam), jnp.sin(gam), jnp.cos(psi), jnp.sin(psi)
    cphi, tphi = jnp.cos(phi), jnp.tan(phi)
    lat_arg = lam1 * lam2 - 1.0 - lam1 * lam1
    c_lat = jnp.sqrt(jnp.maximum(lat_arg, 0.0) + _ROOT_EPS**2) - _ROOT_EPS
    th = jnp.tanh(model.k_chi * chi)
    f1 = v * cg * sp / (r * cphi)
    f2 = v * cg * cp / r
    side = k_lift * th * c_lat / cg                       # lateral-lift term of psi'
    z = jnp.zeros_like(h)
    rows = [
        [z, z, z, sg, v * cg, z, z],
        [-f1 / r, z, f1 * tphi, f1 / v, -v * sg * sp / (r * cphi), v * cg * cp / (r * cphi), z],
        [-f2 / r, z, z, f2 / v, -v * sg * cp / r, -v * cg * sp / r, z],
        [beta * drag + 2.0 * g * sg / r, z, z, -2.0 * drag / v, -g * cg, z, z],
        [-beta * k_lift * lam1 + (-v / r**2 + 2.0 * g / (r * v)) * cg, z, z,
         k_lift * lam1 / v + (1.0 / r + g / v**2) * cg, -(v / r - g / v) * sg, z, z],
        [-beta * side - v / r**2 * cg * sp * tphi, z, v / r * cg * sp * (1.0 + tphi**2),
         side / v + cg * sp * tphi / r, side * sg / cg - v / r * sg * sp * tphi, v / r * cg * cp * tphi,
         k_lift * model.k_chi * (1.0 - th**2) * c_lat / cg],
        [z, z, z, z, z, z, -1.0 / t_chi + z],
    ]
    return jnp.stack([jnp.stack(row) for row in rows])


def propagate_with_jacobian(model: GlideModel, xs, u, dt):
    """(f(x, u), F) in scaled units: f by RK4, F = I + A dt + (A dt)^2 / 2 with
    A the model Jacobian at x (second-order transition matrix). F is a
    constant for reverse-mode AD (``stop_gradient``): training the L-EKF
    differentiates through f, P and K, not through the model's second
    derivatives (the EKF itself takes F as given)."""
    scale = jnp.asarray(STATE_SCALE, xs.dtype)
    A = jacobian(model, jax.lax.stop_gradient(xs) * scale, jax.lax.stop_gradient(u)) * (scale[None, :] / scale[:, None])
    Adt = A * dt
    F = jnp.eye(N_X, dtype=xs.dtype) + Adt + 0.5 * Adt @ Adt
    return propagate(model, xs, u, dt), jax.lax.stop_gradient(F)


def measure(xs):
    """h(x) = H x (eq. 22), scaled units."""
    return xs[:N_Z]


def wrap_innovation(y):
    """Innovation z - h(x) with the longitude component wrapped to (-pi, pi]
    (scaled units: 1 unit = 1 mrad)."""
    half = np.pi / STATE_SCALE[1]
    return y.at[1].set(jnp.mod(y[1] + half, 2.0 * half) - half)


def to_scaled(x_phys):
    return np.asarray(x_phys, float) / STATE_SCALE[: np.shape(x_phys)[-1]]


def to_physical(xs):
    return np.asarray(xs, float) * STATE_SCALE[: np.shape(xs)[-1]]


def covariance_to_physical(P):
    """Scaled-unit covariance (..., 7, 7) -> physical units."""
    s = STATE_SCALE[: np.shape(P)[-1]]
    return np.asarray(P, float) * s[:, None] * s[None, :]


def measurement_to_scaled(z_phys):
    """Radar [alt_m, lon_rad, lat_rad] -> scaled measurement."""
    return np.asarray(z_phys, float) / STATE_SCALE[:N_Z]


def true_inputs(c_l, sigma_rad, t_chi_s):
    """Eq. 14, 17: u = [c_l cos(sigma), (c_l^2 + 1) / (c_l cos(sigma)), T_chi]
    from the vehicle's normalized lift coefficient and bank angle."""
    c_l = np.asarray(c_l, float)
    lam1 = c_l * np.cos(sigma_rad)
    return np.stack([lam1, (c_l**2 + 1.0) / lam1, np.broadcast_to(t_chi_s, lam1.shape)], axis=-1)


def glide_inputs(c_l: float, t_chi_s: float) -> np.ndarray:
    """u of a quasi-equilibrium glide without lateral maneuver (sigma = 0)."""
    return true_inputs(np.array([c_l]), 0.0, t_chi_s)[0]
