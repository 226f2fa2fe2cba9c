"""Glide guidance to a target point: a glide-slope midcourse with lateral
proportional navigation, 3-D proportional navigation in the terminal phase.

Sources: proportional navigation, Zarchan, *Tactical and Strategic Missile
Guidance* (6th ed., AIAA 2012), ch. 2 (eq. 2.1: n_c = N' V_c lambda_dot),
with the gravity term of ch. 2's "PN with gravity compensation"; its use in
the dive phase of hypersonic glide vehicles: Lu, P., "Entry guidance: a
unified method", JGCD 37 (2014), and the midcourse/terminal split of Zhang,
Chen, Xu (seed 002's family of CAV-H studies). The midcourse altitude loop is
the flight-path-angle loop of the truth's own program (``boost_glide.py``).

Geometry (target fixed on the Earth, vehicle at (lat, lon, h) with the
Earth-relative velocity v_enu): rho = (e, n, u) = target - vehicle in the
vehicle's ENU frame (from ECEF), range-to-go s = sqrt(e^2 + n^2), line of
sight azimuth lambda_h = atan2(e, n) and elevation lambda_v = atan2(u, s),
with the rates of the relative motion (rho_dot = -v_enu)::

    lambda_h_dot = (n e_dot - e n_dot) / s^2                           (1)
    lambda_v_dot = (s u_dot - u s_dot) / (s^2 + u^2),  s_dot = (e e_dot + n n_dot) / s   (2)

Loads (in g; n_lat positive to the right, i.e. heading increasing; n_vert
in the vertical plane of v, up)::

    n_lat  = N V_h lambda_h_dot / g0                                   (3)  both phases
    n_vert = (g_eff cos(gamma) + V k_gamma (gamma_c - gamma)) / g0      (4)  midcourse,
             gamma_c = gamma_slope + clip(k_h (h_ref(s) - h) / V, +-gamma_limit),
             h_ref(s) = h_T + (h_0 - h_T) s / s_0,  gamma_slope = -atan((h_0 - h_T) / s_0)
    n_vert = (N V lambda_v_dot + g_eff cos(gamma)) / g0                 (5)  terminal (s < terminal_range_m)

with g_eff = g - V^2 / (R + h) (gravity less the centrifugal relief of the
curved flight). The midcourse follows the straight glide slope from the
guidance's first state (s_0, h_0) to the target (0, h_T): a vehicle that
pushes over by unloading only (n_vert >= n_vert_min, never inverted) turns
its flight path down at most ~g/V (0.2 deg/s at 2.7 km/s), so the terminal
phase must start near the line of sight, not level 20 km above it. Loads -> commands, as the truth's program does::

    sigma_c = atan2(n_lat, max(n_vert, n_vert_min)), |sigma_c| <= bank_limit     (6)
    c_l_c   = hypot(n_lat, n_vert) m g0 / (q S C_L*),  clipped to [c_l_min, c_l_max]   (7)

q = rho(h) V^2 / 2 from the US Standard Atmosphere 1976 and the vehicle's
nominal model (the scenario's ``flight:`` block): the guidance knows the
airframe as its designer does, not the simulated world's state.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core import atmosphere
from hyper_nav_gnss import earth

G0 = earth.G0_MPS2


@dataclass(frozen=True)
class GlideCommand:
    """A command (bank angle, normalized lift coefficient) and what it came from."""
    t_nav_s: float
    sigma_cmd_rad: float
    c_l_cmd: float
    range_to_go_m: float
    terminal: bool
    n_lat_g: float
    n_vert_g: float


class GlideGuidance:
    """Equations (1)-(7) above; ``command(t_s, lat, lon, alt, vel_enu)`` ->
    ``GlideCommand``. State: the glide slope's start (s_0, h_0), latched
    at the first call, and the terminal latch."""

    def __init__(self, cfg, vehicle):
        self.cfg, self.vehicle = cfg, vehicle
        self.slope_start = None                 # (s_0, h_0)
        self.terminal = False
        self._r_t_e = earth.geodetic_to_ecef(cfg.target_lat_rad, cfg.target_lon_rad, cfg.target_alt_m)

    def geometry(self, lat_rad, lon_rad, alt_m):
        """rho = target - vehicle, vehicle ENU (m)."""
        r_v = earth.geodetic_to_ecef(lat_rad, lon_rad, alt_m)
        return np.asarray(earth.C_n_e(lat_rad, lon_rad)).T @ (np.asarray(self._r_t_e) - np.asarray(r_v))

    def command(self, t_s, lat_rad, lon_rad, alt_m, vel_enu_mps) -> GlideCommand:
        cfg, veh = self.cfg, self.vehicle
        e, n, u = (float(x) for x in self.geometry(lat_rad, lon_rad, alt_m))
        vE, vN, vU = (float(x) for x in vel_enu_mps)
        V = math.sqrt(vE * vE + vN * vN + vU * vU)
        Vh = math.hypot(vE, vN)
        s = math.hypot(e, n)
        if self.slope_start is None:
            self.slope_start = (s, float(alt_m))
        de, dn, du = -vE, -vN, -vU
        lam_h_dot = (n * de - e * dn) / (s * s)                                    # (1)
        s_dot = (e * de + n * dn) / s
        lam_v_dot = (s * du - u * s_dot) / (s * s + u * u)                         # (2)
        gam = math.asin(max(-1.0, min(1.0, vU / V)))
        r_m, r_n = earth.radii(lat_rad)
        g = -float(np.asarray(earth.gravity_n(lat_rad, alt_m)).reshape(-1)[2])
        g_eff = g - V * V / (float(r_n) + alt_m)
        N = cfg.navigation_constant
        n_lat = N * Vh * lam_h_dot / G0                                            # (3)
        if s < cfg.terminal_range_m:
            self.terminal = True
        if self.terminal:
            n_vert = (N * V * lam_v_dot + g_eff * math.cos(gam)) / G0              # (5)
        else:
            s0, h0 = self.slope_start
            h_ref = cfg.target_alt_m + (h0 - cfg.target_alt_m) * s / s0
            gam_c = -math.atan((h0 - cfg.target_alt_m) / s0) + max(
                -cfg.gamma_limit_rad, min(cfg.gamma_limit_rad, cfg.k_h_per_s * (h_ref - alt_m) / V))
            n_vert = (g_eff * math.cos(gam) + V * cfg.k_gamma_per_s * (gam_c - gam)) / G0   # (4)
        n_vert = max(n_vert, cfg.n_vert_min_g)
        sigma = max(-cfg.bank_limit_rad, min(cfg.bank_limit_rad, math.atan2(n_lat, n_vert)))   # (6)
        qS = 0.5 * atmosphere.density_kgpm3_scalar(alt_m) * V * V * veh.s_ref_m2
        c_l = math.hypot(n_lat, n_vert) * veh.mass_kg * G0 / (max(qS, 1e-6) * veh.cl_star)   # (7)
        c_l = max(veh.c_l_min, min(veh.c_l_max, c_l))
        return GlideCommand(float(t_s), sigma, c_l, s, self.terminal, n_lat, n_vert)


def miss_enu_m(cfg, lat_rad, lon_rad, alt_m, vel_enu_mps):
    """Miss at the end of a flight: the target relative to the end point in
    the end point's ENU frame (m), split into down-range (along the
    horizontal velocity, positive = the target is still ahead: short) and
    cross-range (positive = the target is to the right). Returns dict with
    miss_m (horizontal distance), down_range_m, cross_range_m, alt_error_m."""
    g = GlideGuidance(cfg, None)
    e, n, u = (float(x) for x in g.geometry(lat_rad, lon_rad, alt_m))
    vE, vN = float(vel_enu_mps[0]), float(vel_enu_mps[1])
    vh = math.hypot(vE, vN)
    ux, uy = vE / vh, vN / vh
    return {"miss_m": math.hypot(e, n), "down_range_m": e * ux + n * uy, "cross_range_m": e * uy - n * ux,
            "alt_error_m": -u}
