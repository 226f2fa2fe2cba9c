"""Elastic (dynamic) lever arm of the IMU, filter side (seed 000, Yang et al.,
eqs. 1-13 and 17-23): the modal model the filter carries, the compensation
of the accelerometer increments, and the Jacobians of the 6 modal error
states. The simulator's truth model (``hyper_nav_sim.core.lever_arm``) uses
the same beam shapes, discretisation and lever-arm acceleration.

Model (eqs. 3, 9-13): three bending modes, q_i'' = K2 q + K1 q' + u_q,
K2 = -diag(w_i^2), K1 = -diag(2 zeta_i w_i), u_q = phi_i F_n / M_i with the
normal load F_n = m_vehicle (e_d . f_b) from the structure's load sensor
(its sub-interval samples, each held over its part of the IMU interval; the
measured specific force without one, see ``LeverArmCompensator``); IMU station r = r0 + Y q, Y = e_d [W_1(x_A) W_2(x_A) W_3(x_A)].
Accelerometer error (eq. 1/13):
    nabla_lever = r'' + 2 w x r' + w' x r + w x (w x r).

Error state ``lev`` = [dq (3), dq' (3)] (estimate minus truth). With the
corrected specific force f_hat = f_meas - nabla_lever(q_hat), its error is
-(A_q dq + A_qd dq'), where (eq. 20, the paper's F4 blocks)
    A_q  = Y K2 + [w' x] Y + [w x][w x] Y,    A_qd = Y K1 + 2 [w x] Y,
so  dv_dot += -C_b_n (A_q dq + A_qd dq')  and  d/dt [dq; dq'] = F5 [dq; dq'] + [0; w_q],
F5 = [[0, I], [K2, K1]] (eq. 18). The deterministic input u_q (eq. 22's B u)
drives the nominal modal state only; its error is neglected (it comes from
the measured specific force).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .attitude import cross3, skew

_FREE_FREE_BETA_L = (4.730040745, 7.853204624, 10.995607838)
TABLE2_FREQ_RADPS = (20.8453, 50.0123, 98.7743)      # seed 000 Table 2 (initial values)
TABLE4_FREQ_RADPS = (20.1658, 55.3610, 113.0664)     # seed 000 Table 4 (real values)


def free_free_beam_mode_shapes(x_over_l) -> np.ndarray:
    """First three bending mode shapes W_i of a uniform free-free beam at
    stations x/l (0 = nose), normalised to mean(W^2) = 1 over the length
    (then M_i = total mass). Shape (..., 3)."""
    xi = np.asarray(x_over_l, float)[..., None]
    bl = np.asarray(_FREE_FREE_BETA_L)
    sig = (np.cosh(bl) - np.cos(bl)) / (np.sinh(bl) - np.sin(bl))
    z = bl * xi
    return np.cosh(z) + np.cos(z) - sig * (np.sinh(z) + np.sin(z))


def zoh_matrices(w, zeta, h):
    """Exact ZOH transition of [s, q, q'] (s = int q over the step) for an
    under-damped mode (zeta < 1), stacks of w, zeta, step h, in closed form:
    with sigma = zeta w, w_d = w sqrt(1 - zeta^2), e = exp(-sigma h),
    q(h) - q_p = e [cos(w_d h) + sigma/w_d sin(w_d h)] (q0 - q_p) + e sin(w_d h)/w_d q0',
    q_p = u / w^2, and int q dt follows from the ODE itself:
    w^2 int (q - q_p) dt = -(q'(h) - q0') - 2 sigma (q(h) - q0).
    Returns Phi (..., 3, 3), Gamma (..., 3) (response to a unit u held over h)."""
    w, zeta = np.broadcast_arrays(np.asarray(w, float), np.asarray(zeta, float))
    sg = zeta * w
    wd = w * np.sqrt(1.0 - zeta**2)
    e = np.exp(-sg * h)
    c, sn = np.cos(wd * h), np.sin(wd * h)
    w2 = w**2
    p_qq = e * (c + sg / wd * sn)
    p_qv = e * sn / wd
    p_vq = -e * w2 / wd * sn
    p_vv = e * (c - sg / wd * sn)
    Phi = np.zeros(w.shape + (3, 3))
    Phi[..., 0, 0] = 1.0
    Phi[..., 0, 1] = -(p_vq + 2.0 * sg * (p_qq - 1.0)) / w2
    Phi[..., 0, 2] = -((p_vv - 1.0) + 2.0 * sg * p_qv) / w2
    Phi[..., 1, 1], Phi[..., 1, 2], Phi[..., 2, 1], Phi[..., 2, 2] = p_qq, p_qv, p_vq, p_vv
    g_q = (1.0 - p_qq) / w2
    g_v = -p_vq / w2
    Gam = np.stack([(h - g_v - 2.0 * sg * g_q) / w2, g_q, g_v], axis=-1)
    return Phi, Gam


def lever_arm_specific_force(r_b_m, rdot_b_mps, rddot_b_mps2, omega_ib_b_radps, omegadot_ib_b_radps2):
    """Eq. 1: r'' + 2 w x r' + w' x r + w x (w x r) (all four terms), (..., 3)."""
    w = omega_ib_b_radps
    return (rddot_b_mps2 + 2.0 * np.cross(w, rdot_b_mps) + np.cross(omegadot_ib_b_radps2, r_b_m)
            + np.cross(w, np.cross(w, r_b_m)))


def lever_arm_dvel(Y, r0_b_m, q_prev, qd_prev, q, qd, q_int, w_start, w_mid, w_end, dt_s) -> np.ndarray:
    """Integral of eq. 1 over IMU intervals (arrays (..., 3)), from the modal
    state at both ends, int q dt, and w_ib at the start, middle and end:

        Y dq'                                   (r'', exact)
      + 2 w_mid x (Y dq)                        (Coriolis, int r' = dr exactly)
      + dw x r0 + (dw / dt) x (Y int q)         (Euler; int w' = dw exactly)
      + Simpson(w x (w x r0)) + w_mid x (w_mid x Y int q)   (centripetal)."""
    Y = np.asarray(Y, float)
    # np.cross costs ~40 us per single-vector call (attitude.cross3; measured: 11 calls were 40 % of
    # the 24-state predict); the filter passes single vectors, the simulator batches
    cross = np.cross if np.ndim(w_mid) > 1 else cross3
    d_rdot = (qd - qd_prev) @ Y.T
    d_r = (q - q_prev) @ Y.T
    r_el = q_int @ Y.T
    r0 = np.asarray(r0_b_m, float)
    dw = w_end - w_start
    cent0 = sum(c * cross(w, cross(w, r0)) for c, w in ((1.0, w_start), (4.0, w_mid), (1.0, w_end))) * dt_s / 6.0
    return (d_rdot + 2.0 * cross(w_mid, d_r) + cross(dw, r0) + cross(dw / dt_s, r_el)
            + cent0 + cross(w_mid, cross(w_mid, r_el)))


@dataclass(frozen=True)
class ModalModel:
    """The filter's model of the structure (FilterConfig ``lever_arm_*`` fields)."""
    r0_b_m: np.ndarray
    natural_freq_radps: np.ndarray
    damping_ratio: np.ndarray
    Y: np.ndarray                  # 3 x 3, r = r0 + Y q
    deflection_axis_b: np.ndarray
    load_gain_kg_per_kg: np.ndarray   # u_q = load_gain * (e_d . f_b): phi_i m_vehicle / M_i

    @classmethod
    def from_config(cls, cfg) -> "ModalModel":
        axis = np.asarray(cfg.lever_arm_deflection_axis_b, float)
        axis = axis / np.linalg.norm(axis)
        return cls(np.asarray(cfg.lever_arm_r0_b_m, float), np.asarray(cfg.lever_arm_natural_freq_radps, float),
                   np.asarray(cfg.lever_arm_damping_ratio, float),
                   np.outer(axis, np.asarray(cfg.lever_arm_mode_shape_at_imu, float)), axis,
                   np.asarray(cfg.lever_arm_load_participation, float) * cfg.lever_arm_vehicle_mass_kg
                   / np.asarray(cfg.lever_arm_generalized_mass_kg, float))

    def with_frequencies(self, natural_freq_radps) -> "ModalModel":
        """The same structure with other natural frequencies (re-estimation, seed 000 section III)."""
        return ModalModel(self.r0_b_m, np.asarray(natural_freq_radps, float), self.damping_ratio, self.Y,
                          self.deflection_axis_b, self.load_gain_kg_per_kg)

    @property
    def K1(self) -> np.ndarray:
        return -np.diag(2.0 * self.damping_ratio * self.natural_freq_radps)

    @property
    def K2(self) -> np.ndarray:
        return -np.diag(self.natural_freq_radps**2)

    def modal_input(self, f_b_mps2) -> np.ndarray:
        """u_q (eq. 9-11) for a lever-arm-free specific force f_b (3,), or
        for each row of sub-interval forces (n, 3) -> (n, 3)."""
        f = np.asarray(f_b_mps2, float)
        if f.ndim == 1:
            return self.load_gain_kg_per_kg * float(np.dot(self.deflection_axis_b, f))
        return (f @ self.deflection_axis_b)[:, None] * self.load_gain_kg_per_kg

    def equilibrium(self, f_b_mps2) -> np.ndarray:
        """[q, q'] at the static deflection under a constant load (sub-interval
        loads (n, 3): the first)."""
        f = np.asarray(f_b_mps2, float).reshape(-1, 3)[0]
        return np.concatenate([self.modal_input(f) / self.natural_freq_radps**2, np.zeros(3)])

    def step(self, lev, u_q, dt_s: float):
        """Exact ZOH step of the nominal modal state lev = [q, q'] under a
        held input u_q (3,), or under n sub-interval inputs u_q (n, 3), each
        held over its equal part dt / n of the interval (the load sensor's
        own samples, ``ImuSample.load_f_b_mps2``): returns (lev at the end,
        int q dt over the whole step)."""
        u = np.asarray(u_q, float).reshape(-1, 3)
        Phi, Gam = zoh_matrices(self.natural_freq_radps, self.damping_ratio, dt_s / len(u))   # (3, 3, 3), (3, 3)
        x = np.stack([np.zeros(3), lev[:3], lev[3:]], axis=-1)                               # (3 modes, [s, q, q'])
        for uj in u:
            x = np.einsum("mij,mj->mi", Phi, x) + Gam * uj[:, None]
        return np.concatenate([x[:, 1], x[:, 2]]), x[:, 0]

    def jacobians(self, omega_ib_b_radps, omegadot_ib_b_radps2):
        """A_q, A_qd of eq. 20: d nabla_lever / dq and / dq' (3 x 3 each)."""
        W = skew(omega_ib_b_radps)
        return (self.Y @ self.K2 + skew(omegadot_ib_b_radps2) @ self.Y + W @ W @ self.Y,
                self.Y @ self.K1 + 2.0 * W @ self.Y)


class LeverArmCompensator:
    """Per-IMU-interval compensation of the velocity increments (the filter's
    "dynamic lever-arm effect error compensation", seed 000 Fig. 3): propagates
    the nominal modal state held in ``NavState.extra['lev']`` and returns the
    increments at the CG plus the angular acceleration the error model needs.

    The modal load u_q (eqs. 4-6) is the lever-arm-free specific force of
    the external loads, the known input U(t) of eq. 22: ``load_f_b_mps2``
    when the data carry it (``ImuSample.load_f_b_mps2``). Without it the
    measured specific force of the interval stands in, and that is a poor
    stand-in on a ringing structure: at the IMU station it holds the elastic
    acceleration e_d . Y q'' itself, with a gain sum_i phi_i W_i(x_A) m / M_i
    = -1.02 on the default beam, so the model's modes are driven at their
    own resonance by the structure's ringing (measured on a seed 000 doublet,
    ``benchmarks/lever_arm_model_fit.py``: modal displacement 6.5x and the
    lever-arm increments 7.6x the simulator's in RMS error, against 1.3 % and
    4 % with the lever-arm-free load; issue 24). Removing the model's own
    lever-arm acceleration from the measured force does not help: the
    measured force is an output of the structure with a non-minimum-phase
    zero (direct gain 1 - 1.02 < 0), and that inversion diverges (explicit,
    previous interval: overflow within seconds; implicit, this interval: a
    closed-loop eigenvalue of 2.5 per 20 ms step)."""

    def __init__(self, model: ModalModel):
        self.model = model

    def compensate(self, lev, dtheta_b_rad, dvel_b_mps, dt_s, w_prev_radps=None, load_f_b_mps2=None):
        """lev: nominal [q, q'] at the interval start; dtheta/dvel: the
        bias-corrected increments; w_prev_radps: mean rate of the previous
        interval (None at the first); load_f_b_mps2: the lever-arm-free
        specific force loading the structure (body FLU, m/s^2), the mean
        over the interval (3,) or over its n equal sub-intervals (n, 3);
        None: the measured dvel / dt. Returns (dvel at the CG, lev at the end, mean
        rate of this interval, angular acceleration)."""
        m = self.model
        w_mid = dtheta_b_rad / dt_s
        w_dot = np.zeros(3) if w_prev_radps is None else (w_mid - w_prev_radps) / dt_s
        f_load = dvel_b_mps / dt_s if load_f_b_mps2 is None else np.asarray(load_f_b_mps2, float)
        lev1, q_int = m.step(lev, m.modal_input(f_load), dt_s)
        dv_lever = lever_arm_dvel(m.Y, m.r0_b_m, lev[:3], lev[3:], lev1[:3], lev1[3:], q_int,
                                  w_mid - 0.5 * dt_s * w_dot, w_mid, w_mid + 0.5 * dt_s * w_dot, dt_s)
        return dvel_b_mps - dv_lever, lev1, w_mid, w_dot
