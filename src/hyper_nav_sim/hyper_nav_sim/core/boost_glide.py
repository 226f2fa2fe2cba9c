"""Point-mass (3-DOF) boost-glide dynamics over the rotating WGS-84 Earth, with exact IMU.

``DynamicTrajectory`` has the interface of :class:`~.trajectory.Trajectory`
(``duration_s``, ``truth(t) -> TruthSample``, ``imu_increments``) but the
flight follows from forces instead of prescribed kinematics.

Equations of motion (ENU navigation frame, geodetic position)
------------------------------------------------------------
State y = (lat, lon, alt, v_E, v_N, v_U, m, sigma, c_l)::

    d(lat, lon, alt)/dt = earth.geodetic_rates(lat, alt, v)
    dv/dt = f_n + g_n - (2 omega_ie_n + omega_en_n) x v
    f_n   = (T x_b + L z_sigma - D x_v) / m

the same navigation equation the ENU mechanization integrates, so that
Coriolis (2 omega_ie x v) and transport-rate terms are exact; the centripetal
acceleration of the Earth's rotation is contained in the WGS-84 normal
gravity g_n (Somigliana, ``earth.gravity_n``). Speed V, flight-path angle
gamma and heading psi (clockwise from north) are the polar coordinates of v;
the velocity vector is integrated instead of (V, gamma, psi) themselves
because (V, gamma, psi) are singular at V = 0 and gamma = +-90 deg (vertical
launch); V_dot, gamma_dot, psi_dot are reported by projecting dv/dt, taken
from the equations of motion (never by finite differences).

Aerodynamics (seed 002 eqs. 7-9, Mach-independent): C_L = c_l C_L*,
C_D = C_D0 + K C_L^2 = (c_l^2 + 1)/2 C_D*, C_L* = sqrt(C_D0/K), C_D* = 2 C_D0,
E* = 1/(2 sqrt(C_D0 K)); L = q S C_L, D = q S C_D, q = rho V^2/2 with rho
from the US Standard Atmosphere 1976 (``atmosphere.py``). Angle of attack from
a linear lift curve through the origin, alpha = C_L / C_L_alpha (a documented
simplification: Newtonian lift is not linear above ~20 deg).

Attitude and angular rate (no Euler-angle singularity)
------------------------------------------------------
C_b_n = C_v_n Rx(sigma) Ry(-alpha): velocity frame v (x along velocity,
y left, z up-ish), bank sigma about the velocity vector (positive right wing
down, lift to the right, psi increases), angle of attack nose-up in FLU.
The velocity frame is built from vectors, x_v = v/V, y_v = unit(u x x_v),
z_v = x_v x y_v with a reference direction u: u = local up in flight, which
makes C_v_n = Rz(pi/2 - psi) Ry(-gamma) exactly; during a vertical launch
u is tilted from "backwards" (-h_A, horizontal opposite to the launch
azimuth A) at lift-off to "up" at burnout, u = cos(phi) up - sin(phi) h_A,
so that u is never parallel to the velocity and the frame (and the body at
pitch 90 deg) is well defined. omega_nb_b follows analytically from
d(x_v, y_v, z_v)/dt (from dv/dt of the equations of motion and du/dt of the
phi program) and the rates of sigma and alpha, which are ODE states with
rate limits:

    dsigma/dt = r_sigma tanh((sigma_cmd - sigma) / (tau_sigma r_sigma))
    dc_l/dt   = r_cl tanh((c_l_cmd - c_l) / (tau_cl r_cl))

so the bank angle and angle of attack, and therefore the body rates, are
continuous (a hypersonic airframe does not step its bank angle).

Guidance: loads -> (c_l, sigma)
-------------------------------
Every instant the commanded lateral load n_lat (maneuver programs, in g,
positive to the right) and a vertical load n_vert from the longitudinal
guidance are translated into a bank angle and a lift coefficient::

    sigma_cmd = atan2(n_lat, n_vert),  c_l_cmd = hypot(n_lat, n_vert) m g0 / (q S C_L*)

c_l_cmd clipped to [c_l_min, c_l_max] (lift saturation: the lateral load is
then not reached). The vertical load holds the flight-path angle at
gamma_cmd: n_vert = (g_eff cos(gamma) + V k_gamma (gamma_cmd - gamma)) / g0,
g_eff = g - V^2/(R + h), not below n_vert_min_g (push-overs by unloading, not
by flying inverted: sigma stays in (-90, 90) deg); gamma_cmd =
k_h (h_ref - h)/V clipped to +-gamma_limit, where h_ref is either the
quasi-equilibrium glide altitude of seed 002 eq. 13 for the nominal
c_l program (rho(h_ref) = 2 m g_eff / (V^2 S C_L* c_l_nom), altitude_mode
"equilibrium_glide") or the start altitude (altitude_mode "hold"), plus the
climb programs. Dive maneuvers override gamma_cmd; pull-up maneuvers add
their load (load_g over a window with ramps ramp_s) to n_vert, a commanded
pull the flight-path loop then brings back. Thrust (boost motor, or
the speed-hold engine of accelerate/cruise programs) acts along the body x
axis.

Boost phase (vertical launch): thrust program (thrust, burn time, mass
flow, tail-off), vertical rise, then a pitch-over kick (negative angle of
attack, sin^2 profile) and a zero-lift gravity turn; after burnout the
glide guidance takes over smoothly (ballistic arc at c_l_max, pull-up into
the equilibrium glide).

Truth and IMU: the dynamics are integrated once with DOP853 (rtol 1e-10,
dense output) between the break points of all programs; ``truth(t)``
evaluates the dense solution and the equations of motion at t, and the IMU
follows from the shared navigation-equation functions of ``trajectory.py``
(``inertial_rates``, ``gauss_legendre_increments``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from hyper_nav_filter.core import atmosphere
from hyper_nav_gnss import earth

from .boost_glide_config import Boost, FlightManeuver, FlightStart, Guidance, Vehicle, parse_flight
from .trajectory import TruthSample, gauss_legendre_increments, inertial_rates

G0 = earth.G0_MPS2
_UP = np.array([0.0, 0.0, 1.0])

LATERAL_TYPES = ("lateral_ca", "square_wave", "evasive", "s_turn", "turn_left", "turn_right")
LONGITUDINAL_TYPES = ("climb", "dive", "glide", "accelerate", "cruise", "pull_up")
MANEUVER_TYPES = LATERAL_TYPES + LONGITUDINAL_TYPES


# ---------------------------------------------------------------------------
# smooth program primitives
def _s(x):
    """Quintic smoothstep on [0, 1] (C2) and its derivative d/dx."""
    x = np.clip(x, 0.0, 1.0)
    return x**3 * (10.0 - 15.0 * x + 6.0 * x**2), 30.0 * x**2 * (1.0 - x) ** 2


def _window(t, t0, t1, ramp):
    """Smooth on/off window: 0 before t0, 1 on [t0 + ramp, t1 - ramp], 0 after t1."""
    ramp = min(ramp, 0.5 * (t1 - t0))
    return _s((t - t0) / ramp)[0] * _s((t1 - t) / ramp)[0]


def _smooth_square(t, t0, period, ramp):
    """+-1 square wave starting at t0 with its rising edge; edges are quintic
    smoothsteps of width ``ramp`` centred on the switching times."""
    ramp = min(ramp, 0.5 * period)
    tau = np.mod(t - t0 + 0.5 * ramp, period) - 0.5 * ramp
    return (-1.0 + 2.0 * _s((tau + 0.5 * ramp) / ramp)[0]
            - 2.0 * _s((tau - 0.5 * period + 0.5 * ramp) / ramp)[0])


# ---------------------------------------------------------------------------
@dataclass
class _Segment:
    t0: float
    t1: float
    sol: object


def _s1(x):
    x = min(max(x, 0.0), 1.0)
    return x**3 * (10.0 - 15.0 * x + 6.0 * x * x)


def _window1(t, t0, t1, ramp):
    ramp = min(ramp, 0.5 * (t1 - t0))
    return _s1((t - t0) / ramp) * _s1((t1 - t) / ramp)


def _square1(t, t0, period, ramp):
    ramp = min(ramp, 0.5 * period)
    tau = (t - t0 + 0.5 * ramp) % period - 0.5 * ramp
    return -1.0 + 2.0 * _s1((tau + 0.5 * ramp) / ramp) - 2.0 * _s1((tau - 0.5 * period + 0.5 * ramp) / ramp)


def _cross1(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def attitude_angles(C_b_n):
    """(roll, pitch, heading) of stacked C_b_n (N, 3, 3) in the convention of
    ``attitude.py``, without warnings or NaN at pitch +-90 deg (there roll is
    set to 0 and the heading taken from the body z axis)."""
    C = np.asarray(C_b_n)
    sp = np.clip(C[:, 2, 0], -1.0, 1.0)
    pitch = np.arcsin(sp)
    roll = np.arctan2(C[:, 2, 1], C[:, 2, 2])
    heading = np.arctan2(C[:, 0, 0], C[:, 1, 0])
    lock = np.sqrt(C[:, 0, 0] ** 2 + C[:, 1, 0] ** 2) < 1e-7
    sgn = np.where(sp >= 0.0, 1.0, -1.0)
    heading = np.where(lock, np.arctan2(-sgn * C[:, 0, 2], -sgn * C[:, 1, 2]), heading)
    roll = np.where(lock, 0.0, roll)
    return roll, pitch, np.mod(heading, 2 * np.pi)


def _unit(w):
    n = np.sqrt(np.sum(w * w, axis=-1, keepdims=True))
    return w / n, n


def _unit_dot(u, n, wdot):
    """d/dt of u = w/|w| given u, |w| and dw/dt."""
    return (wdot - u * np.sum(u * wdot, axis=-1, keepdims=True)) / n


class DynamicTrajectory:
    """Boost-glide truth from point-mass dynamics; same interface as ``Trajectory``."""

    def __init__(self, start: FlightStart, vehicle: Vehicle, maneuvers: list[FlightManeuver],
                 duration_s: float, c_l_program=1.0, guidance: Guidance | None = None,
                 boost: Boost | None = None, end_speed_mps: float | None = None,
                 end_alt_m: float | None = 0.0, rtol: float = 1e-10):
        if start.speed_mps <= 0.0:
            raise ValueError("start.speed_mps: must be > 0 (the velocity frame needs a velocity; "
                             "a vertical launch starts at rail exit)")
        self.start = start
        self.vehicle = vehicle
        self.maneuvers = list(maneuvers)
        self.guidance = guidance or Guidance()
        self.boost = boost
        self.end_speed_mps = end_speed_mps
        self.end_alt_m = end_alt_m
        cl = np.atleast_2d(np.asarray(c_l_program, dtype=float)) if np.ndim(c_l_program) else None
        self._cl_t = np.array([0.0]) if cl is None else cl[:, 0]
        self._cl_v = np.array([float(c_l_program)]) if cl is None else cl[:, 1]
        A = start.psi_rad
        self._h_A = np.array([np.sin(A), np.cos(A), 0.0])
        self._integrate(float(duration_s), rtol)

    # ---- construction from a plain dict -------------------------------------
    @classmethod
    def from_config(cls, d: dict) -> "DynamicTrajectory":
        """Build from a plain dict (a scenario's ``flight:`` section); see
        ``boost_glide_config`` for the fields. Raises ValueError naming the field."""
        return cls(**parse_flight(d))

    # ---- live commands (``commanded_flight.CommandedFlight``) -------------------
    _active_command = None          # (sigma_cmd_rad, c_l_cmd) held by ``_rhs`` over a segment, or None

    def _commands_at(self, t):
        """External commands in force at times t: None (the scheduled program
        flies), or (mask, sigma_cmd_rad, c_l_cmd) arrays; see CommandedFlight."""
        return None

    # ---- programs -----------------------------------------------------------
    def _lateral_load_g(self, t):
        n = np.zeros_like(t)
        for m in self.maneuvers:
            if m.type not in LATERAL_TYPES:
                continue
            w = _window(t, m.t_start_s, m.t_end_s, m.ramp_s)
            if m.type in ("lateral_ca", "turn_right"):
                n = n + m.load_g * w
            elif m.type == "turn_left":
                n = n - m.load_g * w
            elif m.type in ("square_wave", "evasive"):
                n = n + m.load_g * w * _smooth_square(t, m.t_start_s, m.period_s, m.ramp_s)
            elif m.type == "s_turn":
                n = n + m.load_g * w * np.sin(2.0 * np.pi * (t - m.t_start_s) / m.period_s)
        return n

    def _pull_up_load_g(self, t):
        """Vertical load added by ``pull_up`` programs (g, positive up the lift)."""
        n = np.zeros_like(t)
        for m in self.maneuvers:
            if m.type == "pull_up":
                n = n + m.load_g * _window(t, m.t_start_s, m.t_end_s, m.ramp_s)
        return n

    def _longitudinal(self, t):
        """(delta_h_ref, dive weight, dive gamma, engine weight, V_ref, V_ref_dot)."""
        dh = np.zeros_like(t)
        w_dive, g_dive = np.zeros_like(t), np.zeros_like(t)
        w_eng = np.zeros_like(t)
        v_ref, v_ref_dot = np.full(t.shape, self.start.speed_mps), np.zeros_like(t)
        for m in self.maneuvers:
            T = m.t_end_s - m.t_start_s
            if m.type == "climb":
                dh = dh + m.delta_alt_m * _s((t - m.t_start_s) / T)[0]
            elif m.type == "dive":
                w = _window(t, m.t_start_s, m.t_end_s, m.ramp_s)
                g_dive = np.where(w > 0.0, m.gamma_rad, g_dive)
                w_dive = np.maximum(w_dive, w)
            elif m.type in ("accelerate", "cruise"):
                w_eng = np.maximum(w_eng, _window(t, m.t_start_s, m.t_end_s, m.ramp_s))
                if m.type == "accelerate":
                    s, ds = _s((t - m.t_start_s) / T)
                    v_ref = v_ref + m.delta_speed_mps * s
                    v_ref_dot = v_ref_dot + m.delta_speed_mps * ds / T
        return dh, w_dive, g_dive, w_eng, v_ref, v_ref_dot

    def _boost_program(self, t):
        """(thrust, mass flow, alpha program, guidance weight, phi, phi_dot)."""
        z = np.zeros_like(t)
        b = self.boost
        if b is None:
            return z, z, z, np.ones_like(t), z, z
        tb = b.burn_time_s
        thr = np.where(t <= tb, 1.0 - _s((t - (tb - b.tail_off_s)) / b.tail_off_s)[0], 0.0)
        x = np.clip((t - b.vertical_s) / b.pitch_over_s, 0.0, 1.0)
        alpha = -b.pitch_kick_rad * np.sin(np.pi * x) ** 2
        w_g = _s((t - tb) / b.blend_s)[0]
        T_phi = tb - b.vertical_s
        s, ds = _s((t - b.vertical_s) / T_phi)
        phi = 0.5 * np.pi * (1.0 - s)
        phid = -0.5 * np.pi * ds / T_phi
        return b.thrust_n * thr, b.mass_flow_kgps * thr, alpha, w_g, phi, phid

    def c_l_nominal(self, t):
        return np.interp(t, self._cl_t, self._cl_v)

    def break_points(self, t_max):
        pts = {0.0}
        for m in self.maneuvers:
            r = min(m.ramp_s, 0.5 * (m.t_end_s - m.t_start_s))
            pts.update([m.t_start_s, m.t_end_s, m.t_start_s + r, m.t_end_s - r])
            if m.type in ("square_wave", "evasive"):
                rr = min(m.ramp_s, 0.5 * m.period_s)
                e = m.t_start_s - 0.5 * rr
                while e < m.t_end_s:
                    pts.update([e, e + rr])
                    e += 0.5 * m.period_s
        if self.boost is not None:
            b = self.boost
            pts.update([b.vertical_s, b.vertical_s + b.pitch_over_s, b.burn_time_s - b.tail_off_s,
                        b.burn_time_s, b.burn_time_s + b.blend_s])
        pts.update(self._cl_t.tolist())
        return np.array(sorted(p for p in pts if 0.0 <= p < t_max) + [t_max])

    # ---- dynamics -------------------------------------------------------------
    def _eval(self, t, Y, full=False):
        """Equations of motion at times t (N,) and states Y (9, N)."""
        veh, gd = self.vehicle, self.guidance
        lat, lon, alt, vE, vN, vU, m, sig, cl = Y
        v = np.stack([vE, vN, vU], axis=-1)
        V = np.sqrt(vE**2 + vN**2 + vU**2)
        x_v = v / V[:, None]
        T_b, mdot_b, alpha_b, w_g, phi, phid = self._boost_program(t)
        cphi, sphi = np.cos(phi), np.sin(phi)
        u = cphi[:, None] * _UP - sphi[:, None] * self._h_A
        y_v, n_w = _unit(np.cross(u, x_v))
        z_v = np.cross(x_v, y_v)
        # atmosphere and aerodynamics
        rho = atmosphere.density_kgpm3(alt)
        q = 0.5 * rho * V**2
        qS = q * veh.s_ref_m2
        L = qS * veh.cl_star * cl
        D = qS * veh.cd_star * 0.5 * (cl**2 + 1.0)
        alpha = veh.cl_star * cl / veh.cl_alpha_per_rad
        cs, ss, ca, sa = np.cos(sig), np.sin(sig), np.cos(alpha), np.sin(alpha)
        z_sig = cs[:, None] * z_v - ss[:, None] * y_v
        x_b = ca[:, None] * x_v + sa[:, None] * z_sig
        # gravity, Earth rates
        g_n = earth.gravity_n(lat, alt)
        g = -g_n[:, 2]
        r_m, r_n = earth.radii(lat)
        g_eff = g - V**2 / (r_n + alt)
        sgam = np.clip(vU / V, -1.0, 1.0)
        gam = np.arcsin(sgam)
        cgam = np.sqrt(1.0 - sgam**2)
        # longitudinal guidance -> n_vert
        dh, w_dive, g_dive, w_eng, v_ref, v_ref_dot = self._longitudinal(t)
        if gd.altitude_mode == "hold":
            h_ref = self.start.alt_m + dh
        else:
            rho_ref = 2.0 * m * np.maximum(g_eff, 0.05) / (V**2 * veh.s_ref_m2 * veh.cl_star
                                                             * self.c_l_nominal(t))
            h_ref = atmosphere.altitude_for_density_m(rho_ref) + dh
        gam_cmd = np.clip(gd.k_h_per_s * (h_ref - alt) / V, -gd.gamma_limit_rad, gd.gamma_limit_rad)
        gam_cmd = (1.0 - w_dive) * gam_cmd + w_dive * g_dive
        n_vert = np.maximum((g_eff * cgam + V * gd.k_gamma_per_s * (gam_cmd - gam)) / G0, gd.n_vert_min_g)
        n_vert = n_vert + self._pull_up_load_g(t)
        # thrust: boost motor + speed-hold engine along body x
        T_e = m * (v_ref_dot + gd.k_speed_per_s * (v_ref - V)) + D + m * g * sgam
        T_e = w_eng * np.clip(T_e / ca, 0.0, veh.engine_thrust_max_n)
        T = T_b + T_e
        # loads -> (sigma, c_l); the normal component of the thrust, T sin(alpha)
        # at the current alpha, is part of the commanded normal load
        n_lat = self._lateral_load_g(t)
        sig_g = np.arctan2(n_lat, n_vert)
        cl_g = np.clip((np.hypot(n_lat, n_vert) * m * G0 - T_e * sa) / (np.maximum(qS, 1e-6) * veh.cl_star),
                       veh.c_l_min, veh.c_l_max)
        cl_cmd = (1.0 - w_g) * (veh.cl_alpha_per_rad * alpha_b / veh.cl_star) + w_g * cl_g
        sig_cmd = w_g * sig_g
        live = self._commands_at(t)            # external (live) commands replace the program's
        if live is not None:
            on, sig_ext, cl_ext = live
            sig_cmd, cl_cmd = np.where(on, sig_ext, sig_cmd), np.where(on, cl_ext, cl_cmd)
        r_s, r_c = veh.bank_rate_max_radps, veh.c_l_rate_max_per_s
        sig_dot = r_s * np.tanh((sig_cmd - sig) / (veh.bank_time_constant_s * r_s))
        cl_dot = r_c * np.tanh((cl_cmd - cl) / (veh.c_l_time_constant_s * r_c))
        mdot = -(mdot_b + T_e / (veh.engine_isp_s * G0))
        f_n = (T[:, None] * x_b + L[:, None] * z_sig - D[:, None] * x_v) / m[:, None]
        w_ie = earth.omega_ie_n(lat)
        w_en = earth.omega_en_n(lat, alt, v)
        vdot = f_n + g_n - np.cross(2.0 * w_ie + w_en, v)
        pos_dot = earth.geodetic_rates(lat, alt, v)
        dY = np.vstack([pos_dot.T, vdot.T, mdot, sig_dot, cl_dot])
        if not full:
            return dY
        # attitude and its rate
        Vdot = np.sum(x_v * vdot, axis=-1)
        x_dot = (vdot - x_v * Vdot[:, None]) / V[:, None]
        u_dot = phid[:, None] * (-sphi[:, None] * _UP - cphi[:, None] * self._h_A)
        y_dot = _unit_dot(y_v, n_w, np.cross(u_dot, x_v) + np.cross(u, x_dot))
        z_dot = np.cross(x_dot, y_v) + np.cross(x_v, y_dot)
        w_v = np.stack([np.sum(z_v * y_dot, -1), np.sum(x_v * z_dot, -1), np.sum(y_v * x_dot, -1)], axis=-1)
        A = np.stack([x_v, y_v, z_v], axis=-1)                     # C_v_n, columns x_v y_v z_v
        Rx = np.zeros((len(t), 3, 3))
        Rx[:, 0, 0] = 1.0
        Rx[:, 1, 1], Rx[:, 1, 2], Rx[:, 2, 1], Rx[:, 2, 2] = cs, -ss, ss, cs
        Ry = np.zeros((len(t), 3, 3))                              # Ry(-alpha)
        Ry[:, 1, 1] = 1.0
        Ry[:, 0, 0], Ry[:, 0, 2], Ry[:, 2, 0], Ry[:, 2, 2] = ca, -sa, sa, ca
        RxRy = Rx @ Ry
        C_b_n = A @ RxRy
        alpha_dot = veh.cl_star * cl_dot / veh.cl_alpha_per_rad
        # omega_nb_b = (Rx Ry)^T w_v + Ry^T sigma_dot e_x - alpha_dot e_y
        om = np.einsum("kji,kj->ki", RxRy, w_v)
        om = om + np.einsum("kji,kj->ki", Ry, np.stack([sig_dot, 0 * sig_dot, 0 * sig_dot], -1))
        om[:, 1] -= alpha_dot
        e_psi = np.stack([x_v[:, 1], -x_v[:, 0], 0 * V], -1)
        with np.errstate(divide="ignore", invalid="ignore"):
            e_psi = e_psi / cgam[:, None]
            psi_dot = np.sum(e_psi * vdot, -1) / (V * cgam)
            gam_dot = (vdot[:, 2] - sgam * Vdot) / (V * cgam)
        return dict(vel=v, vdot=vdot, C_b_n=C_b_n, omega_nb_b=om, f_n=f_n, V=V, V_dot=Vdot,
                    gamma=gam, gamma_dot=gam_dot, psi=np.mod(np.arctan2(vE, vN), 2 * np.pi),
                    psi_dot=psi_dot, sigma=sig, sigma_dot=sig_dot, alpha=alpha, alpha_dot=alpha_dot,
                    c_l=cl, c_l_cmd=cl_cmd, sigma_cmd=sig_cmd, mass=m, thrust=T, q=q, rho=rho,
                    mach=V / atmosphere.speed_of_sound_mps(alt), h_ref=h_ref, gamma_cmd=gam_cmd,
                    n_lat_cmd_g=n_lat, n_vert_cmd_g=n_vert,
                    n_lat_g=-np.sum(f_n * y_v, -1) / G0, n_vert_g=np.sum(f_n * z_v, -1) / G0,
                    lift=L, drag=D)

    def _rhs_vectorised(self, t, y):
        return self._eval(np.array([t]), y[:, None])[:, 0]

    def _rhs(self, t, y):
        """Scalar twin of ``_eval`` (same formulae with the math module, ~30x
        faster per call for the integrator); tests check that they agree."""
        veh, gd, st = self.vehicle, self.guidance, self.start
        lat, lon, alt, vE, vN, vU, m, sig, cl = (float(x) for x in y)
        V = math.sqrt(vE * vE + vN * vN + vU * vU)
        xv = (vE / V, vN / V, vU / V)
        # boost program
        b = self.boost
        if b is None:
            T_b = mdot_b = alpha_b = phi = 0.0
            w_g = 1.0
        else:
            tb = b.burn_time_s
            T_b = b.thrust_n * (1.0 - _s1((t - (tb - b.tail_off_s)) / b.tail_off_s)) if t <= tb else 0.0
            mdot_b = T_b / b.thrust_n * b.mass_flow_kgps
            x = min(max((t - b.vertical_s) / b.pitch_over_s, 0.0), 1.0)
            alpha_b = -b.pitch_kick_rad * math.sin(math.pi * x) ** 2
            w_g = _s1((t - tb) / b.blend_s)
            phi = 0.5 * math.pi * (1.0 - _s1((t - b.vertical_s) / (tb - b.vertical_s)))
        cphi, sphi = math.cos(phi), math.sin(phi)
        hA = self._h_A
        u = (-sphi * hA[0], -sphi * hA[1], cphi)
        w = _cross1(u, xv)
        nw = math.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2)
        yv = (w[0] / nw, w[1] / nw, w[2] / nw)
        zv = _cross1(xv, yv)
        rho = atmosphere.density_kgpm3_scalar(alt)
        qS = 0.5 * rho * V * V * veh.s_ref_m2
        L = qS * veh.cl_star * cl
        D = qS * veh.cd_star * 0.5 * (cl * cl + 1.0)
        alpha = veh.cl_star * cl / veh.cl_alpha_per_rad
        cs, ss, ca, sa = math.cos(sig), math.sin(sig), math.cos(alpha), math.sin(alpha)
        zs = tuple(cs * zv[i] - ss * yv[i] for i in range(3))
        xb = tuple(ca * xv[i] + sa * zs[i] for i in range(3))
        s2 = math.sin(lat) ** 2
        g0l = earth.G_EQUATOR_MPS2 * (1.0 + earth.K_SOMIGLIANA * s2) / math.sqrt(1.0 - earth.E2 * s2)
        g = g0l * (1.0 - 2.0 / earth.A_M * (1.0 + earth.F + earth.M_RATIO - 2.0 * earth.F * s2) * alt
                   + 3.0 / earth.A_M**2 * alt**2)
        wq = math.sqrt(1.0 - earth.E2 * s2)
        r_n = earth.A_M / wq
        r_m = earth.A_M * (1.0 - earth.E2) / wq**3
        g_eff = g - V * V / (r_n + alt)
        sgam = min(max(vU / V, -1.0), 1.0)
        gam = math.asin(sgam)
        cgam = math.sqrt(1.0 - sgam * sgam)
        # longitudinal programs and guidance
        dh = w_dive = g_dive = w_eng = v_ref_dot = 0.0
        v_ref = st.speed_mps
        n_lat = n_pull = 0.0
        for mv in self.maneuvers:
            T = mv.t_end_s - mv.t_start_s
            typ = mv.type
            if typ == "climb":
                dh += mv.delta_alt_m * _s1((t - mv.t_start_s) / T)
            elif typ == "dive":
                wd = _window1(t, mv.t_start_s, mv.t_end_s, mv.ramp_s)
                if wd > 0.0:
                    g_dive = mv.gamma_rad
                w_dive = max(w_dive, wd)
            elif typ == "pull_up":
                n_pull += mv.load_g * _window1(t, mv.t_start_s, mv.t_end_s, mv.ramp_s)
            elif typ in ("accelerate", "cruise"):
                w_eng = max(w_eng, _window1(t, mv.t_start_s, mv.t_end_s, mv.ramp_s))
                if typ == "accelerate":
                    xx = min(max((t - mv.t_start_s) / T, 0.0), 1.0)
                    v_ref += mv.delta_speed_mps * xx**3 * (10.0 - 15.0 * xx + 6.0 * xx * xx)
                    v_ref_dot += mv.delta_speed_mps * 30.0 * xx * xx * (1.0 - xx) ** 2 / T
            elif typ in LATERAL_TYPES:
                wl = _window1(t, mv.t_start_s, mv.t_end_s, mv.ramp_s)
                if wl == 0.0:
                    continue
                if typ in ("lateral_ca", "turn_right"):
                    n_lat += mv.load_g * wl
                elif typ == "turn_left":
                    n_lat -= mv.load_g * wl
                elif typ in ("square_wave", "evasive"):
                    n_lat += mv.load_g * wl * _square1(t, mv.t_start_s, mv.period_s, mv.ramp_s)
                else:
                    n_lat += mv.load_g * wl * math.sin(2.0 * math.pi * (t - mv.t_start_s) / mv.period_s)
        if gd.altitude_mode == "hold":
            h_ref = st.alt_m + dh
        else:
            rho_ref = 2.0 * m * max(g_eff, 0.05) / (V * V * veh.s_ref_m2 * veh.cl_star
                                                    * float(np.interp(t, self._cl_t, self._cl_v)))
            h_ref = atmosphere.altitude_for_density_m_scalar(rho_ref) + dh
        gam_cmd = min(max(gd.k_h_per_s * (h_ref - alt) / V, -gd.gamma_limit_rad), gd.gamma_limit_rad)
        gam_cmd = (1.0 - w_dive) * gam_cmd + w_dive * g_dive
        n_vert = max((g_eff * cgam + V * gd.k_gamma_per_s * (gam_cmd - gam)) / G0, gd.n_vert_min_g) + n_pull
        T_e = m * (v_ref_dot + gd.k_speed_per_s * (v_ref - V)) + D + m * g * sgam
        T_e = w_eng * min(max(T_e / ca, 0.0), veh.engine_thrust_max_n)
        T_tot = T_b + T_e
        sig_g = math.atan2(n_lat, n_vert)
        cl_g = min(max((math.hypot(n_lat, n_vert) * m * G0 - T_e * sa) / (max(qS, 1e-6) * veh.cl_star),
                       veh.c_l_min), veh.c_l_max)
        cl_cmd = (1.0 - w_g) * (veh.cl_alpha_per_rad * alpha_b / veh.cl_star) + w_g * cl_g
        sig_cmd = w_g * sig_g
        if self._active_command is not None:   # a live command held over this integration segment
            sig_cmd, cl_cmd = self._active_command
        r_s, r_c = veh.bank_rate_max_radps, veh.c_l_rate_max_per_s
        sig_dot = r_s * math.tanh((sig_cmd - sig) / (veh.bank_time_constant_s * r_s))
        cl_dot = r_c * math.tanh((cl_cmd - cl) / (veh.c_l_time_constant_s * r_c))
        mdot = -(mdot_b + T_e / (veh.engine_isp_s * G0))
        f = tuple((T_tot * xb[i] + L * zs[i] - D * xv[i]) / m for i in range(3))
        OM = earth.OMEGA_IE_RADPS
        cl_, sl_ = math.cos(lat), math.sin(lat)
        wx = -vN / (r_m + alt)
        wy = 2.0 * OM * cl_ + vE / (r_n + alt)
        wz = 2.0 * OM * sl_ + vE * sl_ / cl_ / (r_n + alt)
        cor = _cross1((wx, wy, wz), (vE, vN, vU))
        return np.array([vN / (r_m + alt), vE / ((r_n + alt) * cl_), vU,
                         f[0] - cor[0], f[1] - cor[1], f[2] - g - cor[2], mdot, sig_dot, cl_dot])

    def _initial_state(self):
        s = self.start
        v = s.speed_mps * np.array([np.cos(s.gamma_rad) * np.sin(s.psi_rad),
                                    np.cos(s.gamma_rad) * np.cos(s.psi_rad), np.sin(s.gamma_rad)])
        y = np.array([s.lat_rad, s.lon_rad, s.alt_m, *v, self.vehicle.mass_kg, 0.0, 0.0])
        # start in trim: sigma and c_l at their commanded values
        for _ in range(3):
            d = self._eval(np.array([0.0]), y[:, None], full=True)
            y[7], y[8] = d["sigma_cmd"][0], d["c_l_cmd"][0]
        return y

    def _integrate(self, t_max, rtol):
        y = self._initial_state()
        events = []
        if self.end_speed_mps is not None:
            ev = lambda t, y: np.sqrt(y[3]**2 + y[4]**2 + y[5]**2) - self.end_speed_mps  # noqa: E731
            ev.terminal, ev.direction = True, -1
            events.append(ev)
        if self.end_alt_m is not None:
            ea = lambda t, y: y[2] - self.end_alt_m  # noqa: E731
            ea.terminal, ea.direction = True, -1
            events.append(ea)
        atol = np.array([1e-13, 1e-13, 1e-6, 1e-8, 1e-8, 1e-8, 1e-8, 1e-12, 1e-12])
        bp = self.break_points(t_max + 1.0)
        self._segments = []
        t_end = t_max + 1.0
        for t0, t1 in zip(bp[:-1], bp[1:]):
            sol = solve_ivp(self._rhs, (t0, t1), y, method="DOP853", rtol=rtol, atol=atol,
                            dense_output=True, events=events or None, max_step=10.0)
            if not sol.success:
                raise RuntimeError(f"flight integration failed at t = {t0} s: {sol.message}")
            self._segments.append(_Segment(t0, sol.t[-1], sol.sol))
            y = sol.y[:, -1]
            if sol.status == 1:
                t_end = float(sol.t[-1])
                break
        self.terminated_early = t_end < t_max + 1.0
        self.duration_s = min(t_max, t_end)
        self._bounds = np.array([s.t0 for s in self._segments[1:]])

    # ---- truth -------------------------------------------------------------------
    def state(self, t):
        """ODE state (9, N) at times t from the dense output."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        idx = np.searchsorted(self._bounds, t, side="right")
        Y = np.empty((9, len(t)))
        for k in np.unique(idx):
            sel = idx == k
            Y[:, sel] = self._segments[k].sol(t[sel])
        return Y

    def flight(self, t) -> dict:
        """Flight-mechanics quantities at times t: V, gamma, psi and their rates
        (from the equations of motion), sigma, alpha, c_l, loads in g
        (n_lat_g positive right, n_vert_g in the vertical plane of v), mass,
        thrust, dynamic pressure, Mach, guidance commands."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return self._eval(t, self.state(t), full=True)

    def truth(self, t) -> TruthSample:
        """Exact truth (position, velocity, attitude, omega_ib_b, f_b) at times t."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        Y = self.state(t)
        d = self._eval(t, Y, full=True)
        lat, lon, alt = Y[0], Y[1], Y[2]
        omega_ib_b, f_b = inertial_rates(lat, alt, d["vel"], d["vdot"], d["C_b_n"], d["omega_nb_b"])
        roll, pitch, heading = attitude_angles(d["C_b_n"])
        return TruthSample(t, lat, earth.wrap_lon_rad(lon), alt, d["vel"], d["C_b_n"], omega_ib_b, f_b,
                           roll, pitch, heading)

    def imu_increments(self, t_end_s, dt_s):
        """Exact increments (dtheta_b_rad, dvel_b_mps), each (N, 3), over the
        intervals (t - dt, t] for the epochs ``t_end_s``; 4-point Gauss-Legendre."""
        return gauss_legendre_increments(self.truth, t_end_s, dt_s)
