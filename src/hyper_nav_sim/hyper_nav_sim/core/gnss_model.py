"""Loosely coupled GNSS receiver model: antenna position and velocity fixes.

The antenna sits at lever arm l_b (body FLU) from the IMU; the fix is the
antenna truth plus white Gaussian noise with the scenario's 1-sigma values in
ENU (seed 000: 5 m, 0.1 m/s at 10 Hz). Raw pseudoranges come with issue #3.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_gnss import earth


@dataclass
class GnssFixes:
    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    alt_m: np.ndarray
    vel_enu_mps: np.ndarray
    pos_sigma_enu_m: np.ndarray
    vel_sigma_enu_mps: np.ndarray


def simulate_fixes(traj, t_s, pos_sigma_enu_m, vel_sigma_enu_mps, lever_arm_b_m, rng) -> GnssFixes:
    tr = traj.truth(t_s)
    lever = np.asarray(lever_arm_b_m, float)
    l_n = np.einsum("kij,j->ki", tr.C_b_n, lever)
    w_in = earth.omega_ie_n(tr.lat_rad) + earth.omega_en_n(tr.lat_rad, tr.alt_m, tr.vel_enu_mps)
    omega_nb_b = tr.omega_ib_b_radps - np.einsum("kji,kj->ki", tr.C_b_n, w_in)
    v_lever_n = np.einsum("kij,kj->ki", tr.C_b_n, np.cross(omega_nb_b, lever))
    n = len(t_s)
    d_enu = l_n + rng.standard_normal((n, 3)) * np.asarray(pos_sigma_enu_m, float)
    r_m, r_n = earth.radii(tr.lat_rad)
    lat = tr.lat_rad + d_enu[:, 1] / (r_m + tr.alt_m)
    lon = earth.wrap_lon_rad(tr.lon_rad + d_enu[:, 0] / ((r_n + tr.alt_m) * np.cos(tr.lat_rad)))
    alt = tr.alt_m + d_enu[:, 2]
    vel = tr.vel_enu_mps + v_lever_n + rng.standard_normal((n, 3)) * np.asarray(vel_sigma_enu_mps, float)
    return GnssFixes(np.asarray(t_s, float), lat, lon, alt, vel,
                     np.asarray(pos_sigma_enu_m, float), np.asarray(vel_sigma_enu_mps, float))


def parse_outages(value, field: str = "gnss.outages_s") -> tuple:
    """Outage windows [[t0, t1], ...] (s, sim time, t0 < t1): ValueError naming the field."""
    if value is None:
        return ()
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{field}: expected a list of [t0_s, t1_s] windows, got {value!r}")
    out = []
    for i, w in enumerate(value):
        ok = isinstance(w, (list, tuple)) and len(w) == 2 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x) for x in w)
        if not ok or not 0.0 <= float(w[0]) < float(w[1]):
            raise ValueError(f"{field}[{i}]: expected [t0_s, t1_s] with 0 <= t0 < t1, got {w!r}")
        out.append((float(w[0]), float(w[1])))
    return tuple(out)


def drop_outages(fixes: GnssFixes, outages_s) -> GnssFixes:
    """The fixes outside the outage windows [t0, t1) (the noise draws of the
    others are unchanged: the full stream is drawn first)."""
    if not outages_s:
        return fixes
    keep = np.ones(len(fixes.t_s), bool)
    for a, b in outages_s:
        keep &= ~((fixes.t_s >= a) & (fixes.t_s < b))
    return GnssFixes(fixes.t_s[keep], fixes.lat_rad[keep], fixes.lon_rad[keep], fixes.alt_m[keep],
                     fixes.vel_enu_mps[keep], fixes.pos_sigma_enu_m, fixes.vel_sigma_enu_mps)
