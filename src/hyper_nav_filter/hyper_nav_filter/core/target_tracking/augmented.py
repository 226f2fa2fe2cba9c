"""The maneuver as unknown states: the augmented glide model, its posterior
Cramer-Rao bound (PCRB) beside the known-maneuver one, and an EKF on the
augmented state (seed 002 eq. 21 with its inputs estimated). numpy, float64.

Augmented state (``AUG_STATE_NAMES``)::

    y = [h, theta, phi, v, gamma, psi, a_v, a_l, c_d]

the six kinematic states of ``glide_model`` and three maneuver / aerodynamic
parameters: the vertical and lateral normalized lift a_v = c_l cos(sigma)
(= lambda1 of eq. 14) and a_l = c_l sin(sigma) (signed, positive turns to the
right, psi clockwise from north), and the normalized drag c_d (= lambda1
lambda2 = 1 + c_l^2 on the polar of eqs. 7-9, eq. 17). Eq. 21 with these::

    q_s    = rho v^2 S / (2 m)                     (acceleration per unit coefficient)
    v'     = -q_s C_D*/2 c_d - g sin(gamma)
    gamma' = q_s C_L* a_v / v + (v/r - g/v) cos(gamma)
    psi'   = q_s C_L* a_l / (v cos(gamma)) + v/r cos(gamma) sin(psi) tan(phi)
    h', theta', phi' as eq. 21

i.e. eq. 21 with lambda1 = a_v, c_l sin(sigma) tanh(k chi) = a_l (the lateral
direction is the sign of a_l: no chi state, no tanh, psi' linear in a_l and
observable at a_l = 0) and lambda1 lambda2 = c_d. The drag is a state of its
own, not 1 + a_v^2 + a_l^2: tied to the lift, a lateral maneuver's drag
(up to 9x the glide's at 3 g) has zero derivative at a_l = 0 and an EKF
started there cannot follow it (measured: NEES 10-300 on the scenarios, with
the tie); free, every parameter enters eq. 21 linearly, and the filter's
exponential atmosphere (within 17 % of US76) and the unmodelled Earth
rotation have parameters to go to.

The world's truth in these parameters (``equivalent_params``): the
parameters that make eq. 21 reproduce the simulated truth's accelerations
(v', gamma', psi' by central differences of the truth at the radar epochs;
the three equations are linear in a_v, a_l, c_d). They hold the density
error and the Earth rotation the filter's model lacks. The bound is
evaluated along the truth with them, and the perfect-model data are eq. 21
flown with them (a flight that stays on the simulated one, where the flown
c_l and bank in eq. 21 would leave it: 8 km altitude at 817 m/s by the end
of scenario 1 instead of 24 km at 2543 m/s).

Process model of the maneuver parameters (ours; the paper has none): random
walks, a_{k+1} = a_k + w_k, w_k ~ N(0, diag(q_a^2) dt) with q_a per sqrt(s)
(``ManeuverNoise``); the kinematic states are deterministic given the
parameters (eq. 21 by RK4), plus an optional white kinematic noise (the
filter's allowance for the world-model mismatch; zero in the bound).

The PCRB (Tichavsky, Muravchik, Nehorai 1998) for additive Gaussian noise and
the linear radar z = H y + n, n ~ N(0, R) (eq. 22), evaluated along one
reference track (Jacobians at the truth, the usual approximation of the
expectation)::

    P_{k+1|k} = F_k J_k^-1 F_k^T + Q_k ,  J_{k+1} = P_{k+1|k}^-1 + H^T R^-1 H

With the maneuver known, the parameters are given and the bound is the
recursion of the six kinematic states with the 6x6 block of F_k
(``known_bound``); with q_a -> 0 and the parameters' prior -> 0 the
augmented bound tends to it (tested). The truth's parameters come from the
flown c_l and bank angle (the simulator's), used only by the bound and by the
perfect-model data generator, never by the filter.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core.target_tracking import glide_model as gm

AUG_STATE_NAMES = ("h", "theta", "phi", "v", "gamma", "psi", "a_v", "a_l", "c_d")
N_KIN, N_PAR = 6, 3
N_AUG = N_KIN + N_PAR
# physical units per scaled unit: m, rad, rad, m/s, rad, rad, 1, 1, 1 (km, mrad, 100 m/s, mrad, 10 mrad)
AUG_SCALE = np.concatenate([gm.STATE_SCALE[:N_KIN], [1.0, 1.0, 1.0]])
_FD_STEP = 1.0e-4           # central-difference step of the Jacobian, scaled units


@dataclass(frozen=True)
class ManeuverNoise:
    """Random-walk densities of the maneuver parameters (per sqrt(s)) and
    their prior sigma at the hand-over."""
    q_a_v: float = 0.01
    q_a_l: float = 0.01
    q_c_d: float = 0.02
    init_sigma_a_v: float = 0.2
    init_sigma_a_l: float = 0.3
    init_sigma_c_d: float = 0.5

    @property
    def q(self) -> np.ndarray:
        return np.array([self.q_a_v, self.q_a_l, self.q_c_d])

    @property
    def init_sigma(self) -> np.ndarray:
        return np.array([self.init_sigma_a_v, self.init_sigma_a_l, self.init_sigma_c_d])

    def scaled(self, factor: float) -> "ManeuverNoise":
        return ManeuverNoise(*(factor * np.concatenate([self.q, self.init_sigma])))


def params_from_flight(c_l, sigma_rad) -> np.ndarray:
    """(..., 3) [a_v, a_l, c_d] of a flown normalized lift and bank (eqs. 14, 17)."""
    c_l = np.asarray(c_l, float)
    return np.stack([c_l * np.cos(sigma_rad), c_l * np.sin(sigma_rad), 1.0 + c_l**2], axis=-1)


def equivalent_params(model: gm.GlideModel, t_s, x_phys) -> np.ndarray:
    """(N, 3) [a_v, a_l, c_d] that make eq. 21 reproduce the truth's
    accelerations (module doc); x_phys (N, >=6) at the epochs t_s."""
    x = np.asarray(x_phys, float)
    t = np.asarray(t_s, float)
    h, phi, v, gam = x[:, 0], x[:, 2], x[:, 3], x[:, 4]
    psi = np.unwrap(x[:, 5])
    dv, dgam, dpsi = (np.gradient(a, t) for a in (v, gam, psi))
    r = model.earth_radius_m + h
    g = model.g0_mps2 * (model.earth_radius_m / r) ** 2
    rho = model.rho0_kgpm3 * np.exp(-model.beta_per_m * h)
    q_s = rho * v * v * model.s_ref_m2 / (2.0 * model.mass_kg)
    cg = np.cos(gam)
    c_d = -(dv + g * np.sin(gam)) / (0.5 * q_s * model.cd_star)
    a_v = (dgam - (v / r - g / v) * cg) * v / (q_s * model.cl_star)
    a_l = (dpsi - v / r * cg * np.sin(x[:, 5]) * np.tan(phi)) * v * cg / (q_s * model.cl_star)
    return np.stack([a_v, a_l, c_d], axis=-1)


def derivative(model: gm.GlideModel, y: np.ndarray) -> np.ndarray:
    """dy/dt (..., 9), physical units (module doc)."""
    h, phi, v, gam, psi = y[..., 0], y[..., 2], y[..., 3], y[..., 4], y[..., 5]
    a_v, a_l, c_d = y[..., 6], y[..., 7], y[..., 8]
    r = model.earth_radius_m + h
    g = model.g0_mps2 * (model.earth_radius_m / r) ** 2
    rho = model.rho0_kgpm3 * np.exp(-model.beta_per_m * h)
    q_s = rho * v * v * model.s_ref_m2 / (2.0 * model.mass_kg)
    cg, sg = np.cos(gam), np.sin(gam)
    z = np.zeros_like(h)
    return np.stack([
        v * sg,
        v * cg * np.sin(psi) / (r * np.cos(phi)),
        v * cg * np.cos(psi) / r,
        -q_s * 0.5 * model.cd_star * c_d - g * sg,
        q_s * model.cl_star * a_v / v + (v / r - g / v) * cg,
        q_s * model.cl_star * a_l / (v * cg) + v / r * cg * np.sin(psi) * np.tan(phi),
        z, z, z,
    ], axis=-1)


def propagate_phys(model: gm.GlideModel, y: np.ndarray, dt) -> np.ndarray:
    """y(t + dt) by ``model.substeps`` RK4 steps; y (..., 9), dt scalar or (...,)."""
    h = np.asarray(dt, float)[..., None] / model.substeps
    for _ in range(model.substeps):
        k1 = derivative(model, y)
        k2 = derivative(model, y + 0.5 * h * k1)
        k3 = derivative(model, y + 0.5 * h * k2)
        k4 = derivative(model, y + h * k3)
        y = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return y


def transition(model: gm.GlideModel, ys: np.ndarray, dt):
    """(f(y), F) in scaled units for a batch ys (B, 9): f by RK4, F its
    Jacobian by central differences (float64, step 1e-4 scaled units)."""
    ys = np.asarray(ys, float)
    b = ys.shape[0]
    pert = _FD_STEP * np.eye(N_AUG)
    pts = np.concatenate([ys[:, None], ys[:, None] + pert, ys[:, None] - pert], axis=1)    # (B, 19, 9)
    dtb = np.broadcast_to(np.asarray(dt, float), (b,))[:, None]
    out = propagate_phys(model, pts * AUG_SCALE, np.broadcast_to(dtb, pts.shape[:2])) / AUG_SCALE
    F = (out[:, 1:1 + N_AUG] - out[:, 1 + N_AUG:]).transpose(0, 2, 1) / (2.0 * _FD_STEP)
    return out[:, 0], F


def process_noise(noise: ManeuverNoise, dt: float, q_kin_phys=None) -> np.ndarray:
    """Q_k (9, 9) scaled: the parameters' random-walk increments (and an
    optional white kinematic noise, q_kin_phys (6,) per sqrt(s))."""
    q = np.zeros(N_AUG)
    if q_kin_phys is not None:
        q[:N_KIN] = np.asarray(q_kin_phys, float) / AUG_SCALE[:N_KIN]
    q[N_KIN:] = noise.q / AUG_SCALE[N_KIN:]
    return np.diag(q**2 * dt)


# ---------------------------------------------------------------- bounds
def truth_jacobians(model: gm.GlideModel, x_true_phys, params_true, dt: float) -> np.ndarray:
    """(N-1, 9, 9) Jacobians of the augmented discrete model (scaled units)
    along the truth: kinematic states x_true_phys (N, >=6), parameters (N, 3)."""
    y = np.concatenate([np.asarray(x_true_phys, float)[:, :N_KIN], np.asarray(params_true, float)], axis=1)
    return transition(model, y[:-1] / AUG_SCALE, dt)[1]


def _information_recursion(F, P0, R, Q, n):
    H = np.eye(gm.N_Z, n)
    HRH = H.T @ np.linalg.inv(R) @ H
    out = np.empty((len(F) + 1, n, n))
    out[0] = np.linalg.inv(np.linalg.inv(P0) + HRH)
    Q = np.asarray(Q, float)
    for k, Fk in enumerate(F):
        Pp = Fk @ out[k] @ Fk.T + (Q[k] if Q.ndim == 3 else Q)
        Pk = np.linalg.inv(np.linalg.inv(0.5 * (Pp + Pp.T)) + HRH)
        out[k + 1] = 0.5 * (Pk + Pk.T)
    return out


def bound_model(P0_kin: np.ndarray, noise: ManeuverNoise, dt: float, Q_kin: np.ndarray | None = None,
                noise_high: ManeuverNoise | None = None, high_steps=None, n_steps: int | None = None):
    """The prior P0 (9, 9) and the process noise Q (9, 9), or per step (N-1,
    9, 9) with ``noise_high`` and ``high_steps``, of the unknown-maneuver PCRB
    (``augmented_bound``), scaled units."""
    P0 = np.zeros((N_AUG, N_AUG))
    P0[:N_KIN, :N_KIN] = P0_kin[:N_KIN, :N_KIN]
    P0[N_KIN:, N_KIN:] = np.diag((np.maximum(noise.init_sigma, 1e-300) / AUG_SCALE[N_KIN:]) ** 2)
    Q = process_noise(noise, dt)
    if Q_kin is not None:
        Q[:N_KIN, :N_KIN] += Q_kin[:N_KIN, :N_KIN]
    if not np.all(noise.init_sigma > 0):      # a parameter known: keep P0 invertible with a vanishing prior
        P0[N_KIN:, N_KIN:] += np.diag(np.where(noise.init_sigma > 0, 0.0, 1e-24))
    if noise_high is None:
        return P0, Q
    Qh = process_noise(noise_high, dt)
    if Q_kin is not None:
        Qh[:N_KIN, :N_KIN] += Q_kin[:N_KIN, :N_KIN]
    return P0, np.where(np.asarray(high_steps, bool)[:, None, None], Qh, Q)


def augmented_bound(F_aug: np.ndarray, P0_kin: np.ndarray, R: np.ndarray, noise: ManeuverNoise,
                    dt: float, Q_kin: np.ndarray | None = None, noise_high: ManeuverNoise | None = None,
                    high_steps=None) -> np.ndarray:
    """(N, 9, 9) PCRB covariances (scaled units) with the maneuver parameters
    unknown: prior N(truth, diag(init_sigma^2)) beside the kinematic prior
    P0_kin (6, 6, scaled), random walks ``noise`` (Q_kin: kinematic process
    noise per step, scaled; default 0: eq. 21 exact). With ``noise_high`` and
    ``high_steps`` (N-1,) bool, the steps flagged use noise_high's densities:
    the bound of the two-mode (glide / maneuver) model conditioned on the
    true mode sequence, a lower bound for any filter of that model (a filter
    told the modes can only do better; Bessell et al. 2003).

    It bounds the MSE averaged over parameter paths *drawn from these random
    walks*; on one fixed path (a scenario's flight) it is not a bound
    (``flight_bounds``, issue 40: filters go below it there)."""
    P0, Q = bound_model(P0_kin, noise, dt, Q_kin, noise_high, high_steps)
    return _information_recursion(F_aug, P0, R, Q, N_AUG)


def maneuver_steps(params_true, dt: float, rate_per_s: float = 0.01) -> np.ndarray:
    """(N-1,) True where a true parameter changes faster than ``rate_per_s``
    (c_d: 3x faster): the maneuver mode of the conditioned bound."""
    d = np.abs(np.diff(np.asarray(params_true, float), axis=0)) / dt * np.array([1.0, 1.0, 1.0 / 3.0])
    return np.any(d > rate_per_s, axis=1)


def known_bound(F_aug: np.ndarray, P0_kin: np.ndarray, R: np.ndarray, Q_kin: np.ndarray | None = None) -> np.ndarray:
    """(N, 6, 6) PCRB with the maneuver known: the kinematic block of F."""
    F6 = np.asarray(F_aug)[:, :N_KIN, :N_KIN]
    Q = np.zeros((N_KIN, N_KIN)) if Q_kin is None else Q_kin[:N_KIN, :N_KIN]
    return _information_recursion(F6, P0_kin[:N_KIN, :N_KIN], R, Q, N_KIN)


def rms_sigma(P_scaled: np.ndarray, n: int = N_KIN) -> np.ndarray:
    """RMS over time of the bound's standard deviations, physical units (n,)."""
    var = np.diagonal(P_scaled, axis1=1, axis2=2)[:, :n] * AUG_SCALE[:n] ** 2
    return np.sqrt(np.mean(var, axis=0))


# ---------------------------------------------------------------- data on the filter's own model
def perfect_model_truth(model: gm.GlideModel, x0_phys, params_true, dt: float) -> np.ndarray:
    """(N, 6) kinematic truth flown by the augmented model itself with the
    true parameters (N, 3) held over each step: data on which the bound's
    model is exact ("perfect model")."""
    n = len(params_true)
    y = np.concatenate([np.asarray(x0_phys, float)[:N_KIN], params_true[0]])
    out = np.empty((n, N_KIN))
    out[0] = y[:N_KIN]
    for k in range(1, n):
        y[N_KIN:] = params_true[k - 1]
        y = propagate_phys(model, y, dt)
        out[k] = y[:N_KIN]
    return out


# ---------------------------------------------------------------- the filter
@dataclass(frozen=True)
class AugFilterConfig:
    """Augmented EKF (one mode) or IMM over modes that differ only in the
    parameters' random-walk densities (``modes``: glide, maneuver)."""
    modes: tuple = (ManeuverNoise(),)
    q_kin_phys: tuple = (1.0, 1.0e-7, 1.0e-7, 0.3, 1.0e-5, 1.0e-5)     # white kinematic noise per sqrt(s)
    p_stay: float = 0.98                # per mode (a float: the same for every mode)
    params0: tuple = (0.3, 0.0, 1.09)   # initial guess: the nominal glide (c_l = 0.3, sigma = 0)


def _ekf_cycle(model, y, P, qdiag_dt, dt, z, R, half):
    """Predict + update of a batch y (N, 9), P (N, 9, 9); returns y, P, log-likelihood (N,)."""
    y_pred, F = transition(model, y, dt)
    P = F @ P @ F.transpose(0, 2, 1) + qdiag_dt[:, :, None] * np.eye(N_AUG)
    S = P[:, :3, :3] + R
    innov = z - y_pred[:, :3]
    innov[:, 1] = np.mod(innov[:, 1] + half, 2 * half) - half
    K = np.linalg.solve(S, P[:, :3, :]).transpose(0, 2, 1)                 # P H^T S^-1
    y = y_pred + np.einsum("bij,bj->bi", K, innov)
    IKH = np.eye(N_AUG) - np.concatenate([K, np.zeros((len(y), N_AUG, N_AUG - 3))], axis=2)
    P = IKH @ P @ IKH.transpose(0, 2, 1) + K @ R @ K.transpose(0, 2, 1)
    nis = np.einsum("bi,bi->b", innov, np.linalg.solve(S, innov[..., None])[..., 0])
    loglik = -0.5 * (nis + np.log(np.linalg.det(2.0 * np.pi * S)))
    return y, 0.5 * (P + P.transpose(0, 2, 1)), loglik


def aug_filter_run(model: gm.GlideModel, cfg: AugFilterConfig, x0_phys, P0_kin_scaled, R_scaled, Z_scaled, DT):
    """Augmented EKF / IMM over a batch of tracks: x0_phys (B, >=6),
    P0_kin_scaled (6, 6), R_scaled (3, 3), Z_scaled (T, B, 3), DT scalar or
    (T,) (every epoch has a measurement). Returns x (T, B, 9) physical, P
    (T, B, 9, 9) scaled (moment-matched over the modes) and the mode
    probabilities (T, B, M). Cycle of each mode: eqs. 23-27 on y; IMM:
    mixing, mode-matched EKFs, Gaussian likelihoods, moment matching (as
    ``imm``)."""
    Z = np.asarray(Z_scaled, float)
    T, B = Z.shape[:2]
    M = len(cfg.modes)
    DT = np.broadcast_to(np.asarray(DT, float).reshape(-1) if np.ndim(DT) else np.asarray(DT, float), (T,))
    y = np.empty((B, N_AUG))
    y[:, :N_KIN] = np.asarray(x0_phys, float)[:, :N_KIN] / AUG_SCALE[:N_KIN]
    y[:, N_KIN:] = np.asarray(cfg.params0) / AUG_SCALE[N_KIN:]
    P = np.zeros((B, N_AUG, N_AUG))
    P[:, :N_KIN, :N_KIN] = P0_kin_scaled[:N_KIN, :N_KIN]
    P[:, N_KIN:, N_KIN:] = np.diag((cfg.modes[0].init_sigma / AUG_SCALE[N_KIN:]) ** 2)
    ym = np.repeat(y[:, None], M, 1)
    Pm = np.repeat(P[:, None], M, 1)
    mu = np.full((B, M), 1.0 / M)
    p_stay = np.broadcast_to(np.asarray(cfg.p_stay, float), (M,))
    Tm = np.repeat(((1.0 - p_stay) / max(M - 1, 1))[:, None], M, 1)
    np.fill_diagonal(Tm, p_stay if M > 1 else 1.0)
    qd = np.stack([np.diag(process_noise(m, 1.0, cfg.q_kin_phys)) for m in cfg.modes])     # (M, 9) per second
    R = np.asarray(R_scaled, float)
    half = np.pi / AUG_SCALE[1]
    xs, Ps, mus = np.empty((T, B, N_AUG)), np.empty((T, B, N_AUG, N_AUG)), np.empty((T, B, M))
    for k in range(T):
        # mixing: w_{i|j} = T_ij mu_i / c_j
        c = mu @ Tm                                                     # (B, M)
        w = Tm[None] * mu[:, :, None] / c[:, None, :]                   # (B, i, j)
        y0 = np.einsum("bij,bid->bjd", w, ym)
        d = ym[:, :, None, :] - y0[:, None, :, :]                       # (B, i, j, 9)
        P0 = np.einsum("bij,bikl->bjkl", w, Pm) + np.einsum("bij,bijk,bijl->bjkl", w, d, d)
        yn, Pn, ll = _ekf_cycle(model, y0.reshape(B * M, N_AUG), P0.reshape(B * M, N_AUG, N_AUG),
                                np.tile(qd * DT[k], (B, 1)), DT[k], np.repeat(Z[k], M, 0), R, half)
        ym, Pm, ll = yn.reshape(B, M, N_AUG), Pn.reshape(B, M, N_AUG, N_AUG), ll.reshape(B, M)
        logw = np.log(np.maximum(c, 1e-300)) + ll
        logw -= logw.max(1, keepdims=True)
        mu = np.maximum(np.exp(logw), 1e-12)
        mu /= mu.sum(1, keepdims=True)
        xm = np.einsum("bm,bmd->bd", mu, ym)
        dm = ym - xm[:, None]
        xs[k] = xm * AUG_SCALE
        Ps[k] = np.einsum("bm,bmkl->bkl", mu, Pm + np.einsum("bmk,bml->bmkl", dm, dm))
        mus[k] = mu
    return xs, Ps, mus


@dataclass(frozen=True)
class AugmentedSetup:
    """The scenario's ``tracker_augmented:`` block: the glide and maneuver
    modes, the filters built on them and the bound's mode threshold."""
    glide: ManeuverNoise
    maneuver: ManeuverNoise
    p_stay: tuple                       # probability of staying in the glide / the maneuver mode per step
    q_kin_phys: tuple
    maneuver_rate_per_s: float

    @classmethod
    def from_dict(cls, d: dict) -> "AugmentedSetup":
        d = dict(d)
        glide = ManeuverNoise(*(float(d.pop(k)) for k in ("q_a_v", "q_a_l", "q_c_d", "init_sigma_a_v",
                                                          "init_sigma_a_l", "init_sigma_c_d")))
        maneuver = ManeuverNoise(float(d.pop("high_q_a_v")), float(d.pop("high_q_a_l")), float(d.pop("high_q_c_d")),
                                 *(float(v) for v in glide.init_sigma))
        p_stay = (float(d.pop("p_stay")), float(d.pop("p_stay_maneuver")))
        out = cls(glide, maneuver, p_stay, tuple(float(v) for v in d.pop("q_kin")),
                  float(d.pop("maneuver_rate_per_s")))
        if d:
            raise ValueError(f"tracker_augmented: unknown fields {sorted(d)}")
        return out

    def filter_config(self, name: str) -> AugFilterConfig:
        """``AUG-EKF``: one mode (glide); ``AUG-IMM``: glide + maneuver modes."""
        modes = (self.glide,) if name == "AUG-EKF" else (self.glide, self.maneuver)
        return AugFilterConfig(modes=modes, q_kin_phys=self.q_kin_phys, p_stay=self.p_stay[:len(modes)])
