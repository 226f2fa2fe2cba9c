"""Kinematic hypersonic trajectory over the rotating WGS-84 Earth, with exact IMU.

The flight is defined by smooth closed-form profiles of speed V, flight-path
angle gamma, heading psi (clockwise from north), angle of attack alpha and
roll, built from maneuvers (climb, pitch, roll, turn, accelerate). Geodetic
position is the integral of the ENU velocity (DOP853, rtol 1e-12). Angular
rate and specific force follow from the truth by the navigation equations,

    omega_ib_b = omega_nb_b + C_n_b (omega_ie_n + omega_en_n)
    f_b        = C_n_b (dv_n/dt + (2 omega_ie_n + omega_en_n) x v_n - g_n)

with the Earth model of ``hyper_nav_gnss.earth``, and are integrated to
increments over each IMU interval by 4-point Gauss-Legendre quadrature, so an
error-free IMU through the mechanization reproduces the truth.

Longitude is integrated unbounded and wrapped to [-180, 180) deg on output.

Body attitude: heading = psi, pitch = gamma + alpha, roll = roll maneuvers +
coordinated bank atan(V cos(gamma) psi_dot / g0) during turns.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from hyper_nav_gnss import earth

# Which profile each maneuver type drives, and its shape: a "step" changes the
# quantity by `delta` and holds it, a "bump" goes out by `delta` and back.
MANEUVER_KINDS = {
    "climb": ("gamma", "step"),
    "turn": ("psi", "step"),
    "accelerate": ("speed", "step"),
    "pitch": ("alpha", "bump"),
    "roll": ("roll", "bump"),
}
_GL_X, _GL_W = np.polynomial.legendre.leggauss(4)


@dataclass(frozen=True)
class Maneuver:
    type: str
    t_start_s: float
    duration_s: float
    delta: float          # rad for angles, m/s for speed

    def profile(self, t):
        """(value, rate, acceleration) contribution of this maneuver at t."""
        T = self.duration_s
        tau = np.clip((np.asarray(t, dtype=float) - self.t_start_s) / T, 0.0, 1.0)
        inside = (tau > 0.0) & (tau < 1.0)
        two_pi_tau = 2.0 * np.pi * tau
        if MANEUVER_KINDS[self.type][1] == "step":
            val = tau - np.sin(two_pi_tau) / (2.0 * np.pi)
            rate = (1.0 - np.cos(two_pi_tau)) / T
            acc = 2.0 * np.pi * np.sin(two_pi_tau) / T**2
        else:
            val = 0.5 * (1.0 - np.cos(two_pi_tau))
            rate = np.pi * np.sin(two_pi_tau) / T
            acc = 2.0 * np.pi**2 * np.cos(two_pi_tau) / T**2
        return self.delta * val, self.delta * rate * inside, self.delta * acc * inside


@dataclass(frozen=True)
class Start:
    lat_rad: float
    lon_rad: float
    alt_m: float
    speed_mps: float
    gamma_rad: float
    psi_rad: float
    alpha_rad: float
    roll_rad: float


@dataclass
class TruthSample:
    """Truth at times t (arrays with a leading time axis)."""
    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    alt_m: np.ndarray
    vel_enu_mps: np.ndarray
    C_b_n: np.ndarray
    omega_ib_b_radps: np.ndarray
    f_b_mps2: np.ndarray
    roll_rad: np.ndarray
    pitch_rad: np.ndarray
    heading_rad: np.ndarray


def inertial_rates(lat_rad, alt_m, vel_enu_mps, vdot_enu_mps2, C_b_n, omega_nb_b_radps):
    """Gyro and accelerometer truth from the navigation truth (arrays with a
    leading time axis): the navigation equations

        omega_ib_b = omega_nb_b + C_n_b (omega_ie_n + omega_en_n)
        f_b        = C_n_b (dv_n/dt + (2 omega_ie_n + omega_en_n) x v_n - g_n)

    with the Earth model of ``hyper_nav_gnss.earth``. Shared by every
    trajectory generator so that all of them are consistent with the ENU
    mechanization. Returns (omega_ib_b_radps, f_b_mps2), each (N, 3)."""
    w_ie = earth.omega_ie_n(lat_rad)
    w_en = earth.omega_en_n(lat_rad, alt_m, vel_enu_mps)
    g_n = earth.gravity_n(lat_rad, alt_m)
    C_n_b = np.transpose(C_b_n, (0, 2, 1))
    omega_ib_b = omega_nb_b_radps + np.einsum("kij,kj->ki", C_n_b, w_ie + w_en)
    f_n = vdot_enu_mps2 + np.cross(2.0 * w_ie + w_en, vel_enu_mps) - g_n
    f_b = np.einsum("kij,kj->ki", C_n_b, f_n)
    return omega_ib_b, f_b


def gauss_legendre_increments(truth, t_end_s, dt_s):
    """Exact IMU increments (dtheta_b_rad, dvel_b_mps), each (N, 3), over the
    intervals (t - dt, t] for the epochs ``t_end_s``: 4-point Gauss-Legendre
    quadrature of ``truth(t).omega_ib_b_radps`` and ``truth(t).f_b_mps2``
    (``truth`` is a callable returning a :class:`TruthSample`)."""
    t_end_s = np.asarray(t_end_s, dtype=float)
    mid = t_end_s - 0.5 * dt_s
    tq = (mid[:, None] + 0.5 * dt_s * _GL_X[None, :]).ravel()
    tr = truth(tq)
    w = (0.5 * dt_s * _GL_W)[None, :, None]
    dth = (tr.omega_ib_b_radps.reshape(-1, 4, 3) * w).sum(axis=1)
    dv = (tr.f_b_mps2.reshape(-1, 4, 3) * w).sum(axis=1)
    return dth, dv


class Trajectory:
    """Deterministic truth: every node that builds it from the same scenario
    gets the same flight, so sensor nodes need no high-rate truth stream."""

    def __init__(self, start: Start, maneuvers: list[Maneuver], duration_s: float,
                 g0_mps2: float = earth.G0_MPS2):
        self.start = start
        self.maneuvers = list(maneuvers)
        self.duration_s = float(duration_s)
        self._g0 = g0_mps2
        self._ode = solve_ivp(self._rates, (0.0, self.duration_s + 1.0),
                              [start.lat_rad, start.lon_rad, start.alt_m],
                              method="DOP853", rtol=1e-12, atol=[1e-14, 1e-14, 1e-7],
                              dense_output=True, max_step=2.0)
        if not self._ode.success:
            raise RuntimeError(f"trajectory integration failed: {self._ode.message}")

    # ---- profiles -----------------------------------------------------------
    def _profiles(self, t):
        t = np.asarray(t, dtype=float)
        base = {"speed": self.start.speed_mps, "gamma": self.start.gamma_rad,
                "psi": self.start.psi_rad, "alpha": self.start.alpha_rad, "roll": self.start.roll_rad}
        out = {k: [np.full(t.shape, v), np.zeros(t.shape), np.zeros(t.shape)] for k, v in base.items()}
        for m in self.maneuvers:
            key = MANEUVER_KINDS[m.type][0]
            for i, part in enumerate(m.profile(t)):
                out[key][i] = out[key][i] + part
        return out

    def _velocity(self, p):
        V, gam, psi = p["speed"][0], p["gamma"][0], p["psi"][0]
        return np.stack([V * np.cos(gam) * np.sin(psi), V * np.cos(gam) * np.cos(psi), V * np.sin(gam)], axis=-1)

    def _rates(self, t, y):
        v = self._velocity(self._profiles(t))
        return earth.geodetic_rates(y[0], y[2], v)

    # ---- truth ------------------------------------------------------------------
    def truth(self, t) -> TruthSample:
        """Exact truth (position, velocity, attitude, omega_ib_b, f_b) at times t."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        p = self._profiles(t)
        lat, lon, alt = self._ode.sol(t)
        (V, Vd, _), (gam, gamd, _), (psi, psid, psidd) = p["speed"], p["gamma"], p["psi"]
        (alpha, alphad, _), (roll_m, rolld_m, _) = p["alpha"], p["roll"]
        cg, sg, cp, sp = np.cos(gam), np.sin(gam), np.cos(psi), np.sin(psi)
        vel = np.stack([V * cg * sp, V * cg * cp, V * sg], axis=-1)
        vdot = np.stack([Vd * cg * sp - V * sg * gamd * sp + V * cg * cp * psid,
                         Vd * cg * cp - V * sg * gamd * cp - V * cg * sp * psid,
                         Vd * sg + V * cg * gamd], axis=-1)
        # coordinated bank during turns
        u = V * cg * psid / self._g0
        ud = (Vd * cg * psid - V * sg * gamd * psid + V * cg * psidd) / self._g0
        roll = roll_m + np.arctan(u)
        rolld = rolld_m + ud / (1.0 + u**2)
        pitch, pitchd = gam + alpha, gamd + alphad
        # C_b_n = Rz(a) Ry(b) Rx(c), a = pi/2 - heading, b = -pitch, c = roll
        rot = Rotation.from_euler("ZYX", np.stack([np.pi / 2 - psi, -pitch, roll], axis=-1))
        C_b_n = rot.as_matrix()
        ad, bd, cd = -psid, -pitchd, rolld
        sb, cb, sc, cc = np.sin(-pitch), np.cos(-pitch), np.sin(roll), np.cos(roll)
        omega_nb_b = np.stack([cd - ad * sb, bd * cc + ad * cb * sc, -bd * sc + ad * cb * cc], axis=-1)
        omega_ib_b, f_b = inertial_rates(lat, alt, vel, vdot, C_b_n, omega_nb_b)
        return TruthSample(t, lat, earth.wrap_lon_rad(lon), alt, vel, C_b_n, omega_ib_b, f_b, roll, pitch,
                           np.mod(psi, 2 * np.pi))

    def imu_increments(self, t_end_s, dt_s):
        """Exact increments (dtheta_b_rad, dvel_b_mps), each (N, 3), over the
        intervals (t - dt, t] for the epochs ``t_end_s``; 4-point Gauss-Legendre."""
        return gauss_legendre_increments(self.truth, t_end_s, dt_s)

