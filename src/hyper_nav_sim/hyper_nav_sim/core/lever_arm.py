"""Elastic dynamic lever arm of the IMU (seed 000, Yang et al., section II.B).

The vehicle is a free-free slender beam; its transverse deflection is a sum
of natural modes (eq. 2/7)  y(x, t) = sum_i q_i(t) W_i(x),  i = 1..3,  and each
generalized coordinate obeys (eq. 3, with eq. 6's noise w_qi)::

    q_i'' + 2 zeta_i w_i q_i' + w_i^2 q_i = Q_i / M_i + w_qi,

    Q_i = int_0^l f_yb(x) W_i(x) dx,   M_i = int_0^l m(x) W_i(x)^2 dx   (eq. 4).

Generalized force: the normal load is taken as F_n(t) * p(x) (a given total
normal force with a fixed distribution), so Q_i = phi_i F_n(t) with
``load_participation`` phi_i = int p W_i dx (= W_i(x_cp) for a load
concentrated at the centre of pressure). Gravity in eq. 5 acts in
proportion to the mass and, like the rigid-body inertial load, is
orthogonal to the elastic modes of a free-free beam, so it gives no Q_i;
thrust is axial. ``normal_force_from_trajectory`` gives F_n = m f_b,z (the
aerodynamic normal specific force along body up times the vehicle mass).

Lever arm at the IMU (eq. 8, 12)::

    r_A = r_A0 + Y q,   r_A' = Y q',   r_A'' = Y q''   (eq. 9-11: q'' = K1 q' + K2 q + u_q + w_q),
    Y = e_d [W_1(x_A) W_2(x_A) W_3(x_A)]   (3 x 3),

e_d the body deflection axis. Eq. 12 puts the deflection in the second
row, the O_bY_b normal axis of the paper's body frame (x forward, y up,
z right); in this project's body FLU that is +z, the default ``deflection_axis_b``.

Accelerometer error (eq. 1 / 13), all four terms kept, as in the paper::

    nabla_lever = r'' + 2 w_ib x r' + w_ib' x r + w_ib x (w_ib x r),  r = r_A0 + Y q.

Natural frequencies: Table 2 initial values (20.8453, 50.0123, 98.7743 rad/s)
drift linearly to the Table 4 values (20.1658, 55.3610, 113.0664 rad/s)
over ``freq_drift_time_s`` (the paper gives the end points only; the linear
profile is our choice). Damping ratios, mode shapes, generalized masses and
load participation are not given in the paper: defaults are a uniform
free-free beam (beta_i l = 4.7300, 7.8532, 10.9956, modes normalised to
mean(W^2) = 1 so that M_i = vehicle mass), IMU at x/l = 0.30 from the nose,
centre of pressure at x/l = 0.55, 2 % damping, 1000 kg.

Integration (the world is not the filter's model, STYLE pattern 16): two
methods, selected by the scenario's ``world.lever_arm.integrator``.

* ``rk4`` (the realistic world, default for flights): the simulator's own
  method, independent of the filter's discretisation. A fixed-step classical
  Runge-Kutta (4th order, step ``world.lever_arm.step_s``, default 2 ms, an
  integer number of steps per IMU interval) integrates the modal ODE *and*
  eq. 1 itself as one system, [q, q', V] with V' = nabla_lever, with the
  natural frequencies drifting continuously and the normal load, w_ib and
  w_ib' evaluated from the truth at every stage (grid of half steps; w' by
  central differences on that grid). The velocity increment of an IMU
  interval is V(t) - V(t - dt). RK4 on the 113 rad/s mode with 2 ms steps:
  w h = 0.23, phase error (w h)^5 / 120 = 5e-6 rad per step.
  :func:`integrate_modes_rk4` (numba, cached; ``_rk4_kernel.py_func`` is
  the plain reference a test compares with).
* ``zoh`` (the perfect-model world, unit tests): the filter's own exact
  discretisation (closed form for the under-damped oscillator, zeta < 1)
  per IMU interval, with w_i and zeta_i frozen at the interval midpoint and
  the force linear between the interval ends (first-order hold); int q dt is
  carried along, so the velocity increment of the r'' term (Y dq') and the
  integrals of r needed by the w' x r and w x w x r terms are exact for that
  force (:func:`simulate_modes`, :func:`lever_arm_dvel`, which share
  ``zoh_matrices`` and ``lever_arm_dvel`` with the filter). The frequency
  drift is a staircase in the stiffness, equivalent to force steps d(w^2) q:
  about 1e-6 m/s in q' (1e-8 m in q) of mode 3 at 50 Hz with the defaults.
  The rotation terms use w_ib at the start, middle and end of the interval.

The two differ by the integration method only (measured on seed 000, 300 s:
see ``test_lever_arm.py::test_rk4_world_differs_from_the_filter_discretisation``).
Only the accelerometers see the lever arm, as in the paper (eq. 14); the
rotation of the IMU station by the mode slopes W_i'(x_A) q_i' is not
added to the gyros.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy.linalg import expm

# the beam shapes, the exact modal discretisation and eq. 1 are shared with the
# filter's modal model (one implementation)
from hyper_nav_filter.core.elastic_lever_arm import (TABLE2_FREQ_RADPS, TABLE4_FREQ_RADPS,  # noqa: F401
                                                     free_free_beam_mode_shapes)
from hyper_nav_filter.core.elastic_lever_arm import lever_arm_dvel as _lever_arm_dvel
from hyper_nav_filter.core.elastic_lever_arm import zoh_matrices as _zoh_matrices

from hyper_nav_filter.core.params import BOOL, FLOATS, checked, number, unknown_field


_DEFAULTS = {
    "enabled": True,
    "r0_b_m": [0.0, 0.0, 0.0],
    "natural_freq_initial_radps": list(TABLE2_FREQ_RADPS),
    "natural_freq_final_radps": list(TABLE4_FREQ_RADPS),
    "freq_drift_time_s": 300.0,
    "damping_ratio": [0.02, 0.02, 0.02],
    "mode_shape_at_imu": free_free_beam_mode_shapes(0.30).tolist(),
    "deflection_axis_b": [0.0, 0.0, 1.0],
    "generalized_mass_kg": [1000.0, 1000.0, 1000.0],
    "load_participation": free_free_beam_mode_shapes(0.55).tolist(),
    "vehicle_mass_kg": 1000.0,
    "modal_noise_per_sqrt_hz": [0.0, 0.0, 0.0],
    "start_at_equilibrium": True,
    # the load sensor (a second accelerometer triad at the structure's rigid root,
    # ``simulate._measured_load``): its output rate, a whole multiple of the IMU rate
    "load_sensor_rate_hz": 400.0,
}


def _num(name, v, positive=False, nonneg=False):
    return number(name, v, 0.0 if positive or nonneg else None, lo_open=positive, error=ValueError)


def _vec3(name, v, positive=False, nonneg=False):
    return np.array(checked(name, v, FLOATS, length=3, broadcast=False, lo=0.0 if positive or nonneg else None,
                            lo_open=positive, error=ValueError))


def _damping(name, v):
    z = _vec3(name, v, nonneg=True)
    if np.any(z >= 1.0):
        raise ValueError(f"{name}: structural modes are under-damped, need < 1, got {z.tolist()}")
    return z


@dataclass(frozen=True)
class LeverArmConfig:
    enabled: bool
    r0_b_m: np.ndarray                      # rigid lever arm CG -> IMU, body FLU [m]
    natural_freq_initial_radps: np.ndarray  # Table 2
    natural_freq_final_radps: np.ndarray    # Table 4
    freq_drift_time_s: float
    damping_ratio: np.ndarray
    mode_shape_at_imu: np.ndarray           # W_i(x_A), dimensionless
    deflection_axis_b: np.ndarray           # unit vector, body FLU
    generalized_mass_kg: np.ndarray
    load_participation: np.ndarray          # phi_i: Q_i = phi_i F_n
    vehicle_mass_kg: float
    modal_noise_per_sqrt_hz: np.ndarray     # w_qi PSD^(1/2), [q units / s^2 / sqrt(Hz)]
    start_at_equilibrium: bool
    load_sensor_rate_hz: float = 400.0      # the structure-load triad's output rate [Hz]

    @classmethod
    def from_config(cls, d: dict | None, prefix: str = "lever_arm") -> "LeverArmConfig":
        """From the ``lever_arm:`` block (all fields optional, defaults in
        ``_DEFAULTS``); ValueError names a bad field."""
        d = {} if d is None else d
        if not isinstance(d, dict):
            raise ValueError(f"{prefix}: expected a mapping, got {d!r}")
        for k in d:
            if k not in _DEFAULTS:
                raise ValueError(unknown_field(f"{prefix}.", k, _DEFAULTS))
        g = {**_DEFAULTS, **d}
        n = lambda k: f"{prefix}.{k}"  # noqa: E731
        for k in ("enabled", "start_at_equilibrium"):
            checked(n(k), g[k], BOOL, error=ValueError)
        axis = _vec3(n("deflection_axis_b"), g["deflection_axis_b"])
        if np.linalg.norm(axis) == 0:
            raise ValueError(f"{n('deflection_axis_b')}: must be non-zero")
        return cls(
            enabled=g["enabled"],
            r0_b_m=_vec3(n("r0_b_m"), g["r0_b_m"]),
            natural_freq_initial_radps=_vec3(n("natural_freq_initial_radps"), g["natural_freq_initial_radps"],
                                             positive=True),
            natural_freq_final_radps=_vec3(n("natural_freq_final_radps"), g["natural_freq_final_radps"],
                                           positive=True),
            freq_drift_time_s=_num(n("freq_drift_time_s"), g["freq_drift_time_s"], nonneg=True),
            damping_ratio=_damping(n("damping_ratio"), g["damping_ratio"]),
            mode_shape_at_imu=_vec3(n("mode_shape_at_imu"), g["mode_shape_at_imu"]),
            deflection_axis_b=axis / np.linalg.norm(axis),
            generalized_mass_kg=_vec3(n("generalized_mass_kg"), g["generalized_mass_kg"], positive=True),
            load_participation=_vec3(n("load_participation"), g["load_participation"]),
            vehicle_mass_kg=_num(n("vehicle_mass_kg"), g["vehicle_mass_kg"], positive=True),
            modal_noise_per_sqrt_hz=_vec3(n("modal_noise_per_sqrt_hz"), g["modal_noise_per_sqrt_hz"], nonneg=True),
            start_at_equilibrium=g["start_at_equilibrium"],
            load_sensor_rate_hz=_num(n("load_sensor_rate_hz"), g["load_sensor_rate_hz"], positive=True),
        )

    @property
    def Y(self) -> np.ndarray:
        """Mode-shape matrix of eq. 12 in body FLU: r = r0 + Y q."""
        return np.outer(self.deflection_axis_b, self.mode_shape_at_imu)

    def natural_freq_radps(self, t_s) -> np.ndarray:
        """w_i(t), shape (..., 3): Table 2 values drifting linearly to Table 4
        values over freq_drift_time_s (constant afterwards)."""
        t = np.asarray(t_s, float)[..., None]
        if self.freq_drift_time_s <= 0.0:
            frac = np.ones_like(t)
        else:
            frac = np.clip(t / self.freq_drift_time_s, 0.0, 1.0)
        w0, w1 = self.natural_freq_initial_radps, self.natural_freq_final_radps
        return w0 + frac * (w1 - w0)

    def modal_force_per_mass(self, load_n) -> np.ndarray:
        """u_qi = Q_i / M_i for a normal load F_n [N] (shape (..., 3))."""
        return np.asarray(load_n, float)[..., None] * self.load_participation / self.generalized_mass_kg


@dataclass
class ModalResponse:
    """Modal state at the epochs t_s (end of each interval) and the lever arm
    at the IMU in body FLU. ``q_int`` is int q dt over the interval ending at t."""
    t_s: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    q_int: np.ndarray
    q0: np.ndarray           # state at the start of the first interval
    qdot0: np.ndarray
    r_b_m: np.ndarray
    rdot_b_mps: np.ndarray
    rddot_b_mps2: np.ndarray


def _zoh_matrices_expm(w, zeta, h):
    """Reference (slow) ZOH transition by the Van Loan matrix exponential."""
    shape = np.shape(w)
    F = np.zeros(shape + (4, 4))
    F[..., 0, 1] = 1.0
    F[..., 1, 2] = 1.0
    F[..., 2, 1] = -np.asarray(w) ** 2
    F[..., 2, 2] = -2.0 * np.asarray(zeta) * np.asarray(w)
    F[..., 2, 3] = 1.0
    E = expm((F * h).reshape(-1, 4, 4)).reshape(shape + (4, 4))
    return E[..., :3, :3], E[..., :3, 3]


def simulate_modes(cfg: LeverArmConfig, t_end_s, dt_s: float, load_n_at, rng=None,
                   q0=None, qdot0=None) -> ModalResponse:
    """Integrate the three modal equations (eq. 3/6) over the uniform
    intervals (t - dt, t] ending at ``t_end_s``. ``load_n_at(t)`` is the normal
    load F_n [N] (vectorised over t), taken linear between the interval ends
    (first-order hold, so the sampling does not itself excite the modes);
    the optional modal noise w_q is held constant over each interval. Exact
    solution per interval for that force with w_i, zeta_i frozen at the
    interval midpoint: for u = a + b t the particular solution is
    q_p = (a + b t) / w^2 - 2 sigma b / w^4, the rest is the free response
    (``_zoh_matrices``). Initial state at the start of the first interval:
    q0, qdot0 if given, else the static equilibrium u_q / w^2
    (``start_at_equilibrium``) or rest."""
    t_end = np.asarray(t_end_s, float)
    n = len(t_end)
    t_mid = t_end - 0.5 * dt_s
    t_start = t_end[0] - dt_s
    w_mid = cfg.natural_freq_radps(t_mid)                       # (n, 3)
    zeta = np.broadcast_to(cfg.damping_ratio, w_mid.shape)
    u_nodes = cfg.modal_force_per_mass(load_n_at(np.concatenate([[t_start], t_end])))   # (n + 1, 3)
    a_all = u_nodes[:-1].copy()
    b_all = (u_nodes[1:] - u_nodes[:-1]) / dt_s
    if np.any(cfg.modal_noise_per_sqrt_hz > 0.0):
        if rng is None:
            raise ValueError("lever_arm.modal_noise_per_sqrt_hz > 0 needs a numpy Generator")
        a_all += rng.standard_normal((n, 3)) * cfg.modal_noise_per_sqrt_hz / np.sqrt(dt_s)
    Phi, _ = _zoh_matrices(w_mid, zeta, dt_s)                   # (n, 3, 3, 3)
    pqq, pqv, pvq, pvv = Phi[..., 1, 1], Phi[..., 1, 2], Phi[..., 2, 1], Phi[..., 2, 2]
    w2 = w_mid**2
    sg = zeta * w_mid
    if q0 is None:
        w0 = cfg.natural_freq_radps(t_start)
        q0 = u_nodes[0] / w0**2 if cfg.start_at_equilibrium else np.zeros(3)
    q0 = np.asarray(q0, float)
    qdot0 = np.zeros(3) if qdot0 is None else np.asarray(qdot0, float)
    q, qd, qi = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    h = dt_s
    # per-interval constants of the particular (ramp) solution
    qp0 = a_all / w2 - 2.0 * sg * b_all / w2**2
    qp1 = qp0 + b_all * h / w2
    vp = b_all / w2
    qp_int = (a_all * h + 0.5 * b_all * h * h) / w2 - 2.0 * sg * b_all * h / w2**2
    x_q, x_v = q0.copy(), qdot0.copy()
    for k in range(n):
        y0 = x_q - qp0[k]
        yd0 = x_v - vp[k]
        y1 = pqq[k] * y0 + pqv[k] * yd0
        yd1 = pvq[k] * y0 + pvv[k] * yd0
        qi[k] = qp_int[k] - ((yd1 - yd0) + 2.0 * sg[k] * (y1 - y0)) / w2[k]
        x_q = qp1[k] + y1
        x_v = vp[k] + yd1
        q[k], qd[k] = x_q, x_v
    w_end = cfg.natural_freq_radps(t_end)
    u_end = u_nodes[1:] + (a_all - u_nodes[:-1])               # + the held noise, if any
    qdd = -2.0 * cfg.damping_ratio * w_end * qd - w_end**2 * q + u_end
    Y = cfg.Y
    return ModalResponse(t_end, q, qd, qdd, qi, q0, qdot0,
                         cfg.r0_b_m + q @ Y.T, qd @ Y.T, qdd @ Y.T)


def lever_arm_dvel(cfg: LeverArmConfig, resp: ModalResponse, dt_s: float,
                   omega_start_radps, omega_mid_radps, omega_end_radps) -> np.ndarray:
    """Integral of eq. 1 over each interval, (N, 3) [m/s], from w_ib at the
    start, middle and end of each interval:

        Y dq'                                   (r'', exact for the ZOH force)
      + 2 w_mid x (Y dq)                        (Coriolis, int r' = dr exactly)
      + dw x r0 + (dw / dt) x (Y int q)         (Euler; int w' = dw exactly, so a
                                                 jump of w' inside the interval is kept)
      + Simpson(w x (w x r0)) + w_mid x (w_mid x Y int q)   (centripetal)."""
    q_prev = np.vstack([resp.q0[None, :], resp.q[:-1]])
    qd_prev = np.vstack([resp.qdot0[None, :], resp.qdot[:-1]])
    return _lever_arm_dvel(cfg.Y, cfg.r0_b_m, q_prev, qd_prev, resp.q, resp.qdot, resp.q_int,
                           omega_start_radps, omega_mid_radps, omega_end_radps, dt_s)


def normal_force_from_trajectory(traj, mass_kg: float):
    """F_n(t) = m f_b,z(t): aerodynamic normal force along body up [N]."""
    def load(t):
        return mass_kg * traj.truth(np.atleast_1d(t)).f_b_mps2[:, 2]
    return load


def body_rates_at(traj, t_s, h_s: float = 1e-3):
    """(omega_ib_b, d omega_ib_b / dt) at times t from the truth (central difference)."""
    t = np.asarray(t_s, float)
    tr = traj.truth(np.concatenate([t - h_s, t, t + h_s])).omega_ib_b_radps
    n = len(t)
    return tr[n:2 * n], (tr[2 * n:] - tr[:n]) / (2.0 * h_s)


def interval_rates(traj, t_end_s, dt_s: float):
    """omega_ib_b at the start, middle and end of each interval (t - dt, t]."""
    t = np.asarray(t_end_s, float)
    n = len(t)
    w = traj.truth(np.concatenate([t - dt_s, t - 0.5 * dt_s, t])).omega_ib_b_radps
    return w[:n], w[n:2 * n], w[2 * n:]


INTEGRATORS = ("rk4", "zoh")


def add_lever_arm_to_increments(dvel_b_mps, t_end_s, dt_s: float, traj, cfg: LeverArmConfig,
                                load_n_at=None, rng=None, return_response: bool = False,
                                integrator: str = "rk4", step_s: float = 0.002):
    """Velocity increments of the IMU at the elastic lever arm: the exact
    (CG) increments plus the integral of eq. 1 over each interval, by the
    simulator's own fine-step Runge-Kutta (``integrator='rk4'``, realistic
    world) or by the filter's exact discretisation (``'zoh'``, perfect-model
    world), see the module docstring. With ``cfg.enabled`` false the input
    array is returned unchanged. The default load is
    ``normal_force_from_trajectory(traj, cfg.vehicle_mass_kg)``."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"world.lever_arm.integrator: expected one of {INTEGRATORS}, got {integrator!r}")
    if not cfg.enabled:
        return (dvel_b_mps, None) if return_response else dvel_b_mps
    t_end = np.asarray(t_end_s, float)
    if integrator == "rk4":
        dv, resp = integrate_modes_rk4(cfg, t_end, dt_s, traj, step_s, load_n_at, rng)
        out = dvel_b_mps + dv
        return (out, resp) if return_response else out
    if load_n_at is None:
        load_n_at = normal_force_from_trajectory(traj, cfg.vehicle_mass_kg)
    resp = simulate_modes(cfg, t_end, dt_s, load_n_at, rng)
    out = dvel_b_mps + lever_arm_dvel(cfg, resp, dt_s, *interval_rates(traj, t_end, dt_s))
    return (out, resp) if return_response else out


@numba.njit(cache=True)
def _rk4_kernel(h, q0, v0, w_nodes, zeta, u_nodes, u_held, om_nodes, omd_nodes, Y, r0):
    """Classical RK4 over n = len(u_held) steps of [q, q', V, S] (modes,
    their rates, V' = eq. 1, S' = q). Stage inputs at the half-step nodes
    (index 2k = t_k, 2k + 1 = t_k + h/2, 2k + 2 = t_{k+1}): natural
    frequencies w_nodes, modal force per mass u_nodes, body rate om_nodes and
    its derivative omd_nodes, each (2n + 1, 3); u_held (n, 3) is added to the
    force over each step (held modal noise). Returns q, q', V, S at the n + 1
    step ends (n + 1, 3) each."""
    n = u_held.shape[0]
    q = np.empty((n + 1, 3))
    v = np.empty((n + 1, 3))
    V = np.zeros((n + 1, 3))
    S = np.zeros((n + 1, 3))
    q[0] = q0
    v[0] = v0
    kq = np.empty((4, 3))
    kv = np.empty((4, 3))
    kV = np.empty((4, 3))
    kS = np.empty((4, 3))
    xq = np.empty(3)
    xv = np.empty(3)
    acc = np.empty(3)
    r = np.empty(3)
    rd = np.empty(3)
    rdd = np.empty(3)
    wr = np.empty(3)
    for k in range(n):
        for s in range(4):
            if s == 0:
                j, c = 2 * k, 0.0
            elif s == 3:
                j, c = 2 * k + 2, 1.0
            else:
                j, c = 2 * k + 1, 0.5
            for i in range(3):
                if s == 0:
                    xq[i] = q[k, i]
                    xv[i] = v[k, i]
                else:
                    xq[i] = q[k, i] + c * h * kq[s - 1, i]
                    xv[i] = v[k, i] + c * h * kv[s - 1, i]
            for i in range(3):
                w = w_nodes[j, i]
                acc[i] = -2.0 * zeta[i] * w * xv[i] - w * w * xq[i] + u_nodes[j, i] + u_held[k, i]
                kq[s, i] = xv[i]
                kv[s, i] = acc[i]
                kS[s, i] = xq[i]
            for a in range(3):
                r[a] = r0[a]
                rd[a] = 0.0
                rdd[a] = 0.0
                for i in range(3):
                    r[a] += Y[a, i] * xq[i]
                    rd[a] += Y[a, i] * xv[i]
                    rdd[a] += Y[a, i] * acc[i]
            o0, o1, o2 = om_nodes[j, 0], om_nodes[j, 1], om_nodes[j, 2]
            d0, d1, d2 = omd_nodes[j, 0], omd_nodes[j, 1], omd_nodes[j, 2]
            # w x r, then eq. 1: r'' + 2 w x r' + w' x r + w x (w x r)
            wr[0] = o1 * r[2] - o2 * r[1]
            wr[1] = o2 * r[0] - o0 * r[2]
            wr[2] = o0 * r[1] - o1 * r[0]
            kV[s, 0] = (rdd[0] + 2.0 * (o1 * rd[2] - o2 * rd[1]) + (d1 * r[2] - d2 * r[1])
                        + (o1 * wr[2] - o2 * wr[1]))
            kV[s, 1] = (rdd[1] + 2.0 * (o2 * rd[0] - o0 * rd[2]) + (d2 * r[0] - d0 * r[2])
                        + (o2 * wr[0] - o0 * wr[2]))
            kV[s, 2] = (rdd[2] + 2.0 * (o0 * rd[1] - o1 * rd[0]) + (d0 * r[1] - d1 * r[0])
                        + (o0 * wr[1] - o1 * wr[0]))
        for i in range(3):
            q[k + 1, i] = q[k, i] + h / 6.0 * (kq[0, i] + 2.0 * kq[1, i] + 2.0 * kq[2, i] + kq[3, i])
            v[k + 1, i] = v[k, i] + h / 6.0 * (kv[0, i] + 2.0 * kv[1, i] + 2.0 * kv[2, i] + kv[3, i])
            V[k + 1, i] = V[k, i] + h / 6.0 * (kV[0, i] + 2.0 * kV[1, i] + 2.0 * kV[2, i] + kV[3, i])
            S[k + 1, i] = S[k, i] + h / 6.0 * (kS[0, i] + 2.0 * kS[1, i] + 2.0 * kS[2, i] + kS[3, i])
    return q, v, V, S


def integrate_modes_rk4(cfg: LeverArmConfig, t_end_s, dt_s: float, traj, step_s: float = 0.002,
                        load_n_at=None, rng=None, q0=None, qdot0=None, kernel=None):
    """The simulator's own integration of the modal equations (eq. 3/6) and
    of eq. 1 over the uniform IMU intervals (t - dt, t] ending at
    ``t_end_s`` (see the module docstring). Returns (dv (N, 3) [m/s], the
    :class:`ModalResponse` at the interval ends; ``q_int`` = int q dt over
    each interval). ``step_s`` is rounded down to dt / ceil(dt / step_s).
    ``kernel``: None (compiled) or ``_rk4_kernel.py_func`` (reference)."""
    t_end = np.asarray(t_end_s, float)
    n_int = len(t_end)
    m = int(np.ceil(dt_s / step_s - 1e-9))
    h = dt_s / m
    t0 = t_end[0] - dt_s
    # nodes every h/2 from the start of the first interval to the end of the last
    t_nodes = t0 + 0.5 * h * np.arange(2 * m * n_int + 1)
    tr = traj.truth(np.concatenate([[t0 - 0.5 * h], t_nodes, [t_nodes[-1] + 0.5 * h]]))
    om_all = tr.omega_ib_b_radps
    om = om_all[1:-1]
    omd = (om_all[2:] - om_all[:-2]) / h                          # central difference over +-h/2
    load = (cfg.vehicle_mass_kg * tr.f_b_mps2[1:-1, 2]) if load_n_at is None else load_n_at(t_nodes)
    u = cfg.modal_force_per_mass(load)
    w = cfg.natural_freq_radps(t_nodes)
    held = np.zeros((n_int, 3))
    if np.any(cfg.modal_noise_per_sqrt_hz > 0.0):
        if rng is None:
            raise ValueError("lever_arm.modal_noise_per_sqrt_hz > 0 needs a numpy Generator")
        held = rng.standard_normal((n_int, 3)) * cfg.modal_noise_per_sqrt_hz / np.sqrt(dt_s)
    if q0 is None:
        q0 = u[0] / w[0] ** 2 if cfg.start_at_equilibrium else np.zeros(3)
    q0 = np.asarray(q0, float)
    qdot0 = np.zeros(3) if qdot0 is None else np.asarray(qdot0, float)
    run = _rk4_kernel if kernel is None else kernel
    q, qd, V, S = run(h, q0, qdot0, np.ascontiguousarray(w), np.ascontiguousarray(cfg.damping_ratio, float),
                      np.ascontiguousarray(u), np.repeat(held, m, axis=0), np.ascontiguousarray(om),
                      np.ascontiguousarray(omd), np.ascontiguousarray(cfg.Y), np.ascontiguousarray(cfg.r0_b_m))
    ends = m * np.arange(n_int + 1)
    dv = np.diff(V[ends], axis=0)
    q_e, qd_e = q[ends[1:]], qd[ends[1:]]
    w_end = cfg.natural_freq_radps(t_end)
    qdd = -2.0 * cfg.damping_ratio * w_end * qd_e - w_end ** 2 * q_e + u[2 * ends[1:]] + held
    Y = cfg.Y
    resp = ModalResponse(t_end, q_e, qd_e, qdd, np.diff(S[ends], axis=0), q0, qdot0,
                         cfg.r0_b_m + q_e @ Y.T, qd_e @ Y.T, qdd @ Y.T)
    return dv, resp
