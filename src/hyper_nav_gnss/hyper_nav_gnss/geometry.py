"""Receiver-satellite geometry: light-time (transmit-time) solution with the
Sagnac rotation (elevation/azimuth in the receiver's ENU frame: ``earth.elevation_azimuth``).

The signal received at true time t (continuous GPST) left the satellite at
t - tau; its position then, r_sat(t - tau), is expressed in the Earth-fixed
frame of the transmit time, ECEF(t - tau). Seen in ECEF(t) it is
R3(we tau) r_sat(t - tau) (the Earth turned by we tau during the transit:
Sagnac), with R3 the frame rotation about z. tau solves
tau = |R3(we tau) r_sat(t - tau) - r_rx| / c (fixed-point iteration; four
iterations reach 1e-13 s for a receiver anywhere near the Earth).
"""
from __future__ import annotations

import numpy as np

from hyper_nav_gnss.earth import elevation_azimuth  # noqa: F401  (its home is earth; named here too)
from hyper_nav_gnss.orbits.ephemeris import C_MPS, EphemerisStack, constants, satellite_position_ecef, system_time_s


def rot3(theta):
    """Frame rotation about z by ``theta`` (array, shape S) and its derivative
    d/dtheta: two arrays of shape S + (3, 3)."""
    c, s = np.cos(theta), np.sin(theta)
    z = np.zeros_like(theta)
    o = np.ones_like(theta)
    R = np.stack([np.stack([c, s, z], -1), np.stack([-s, c, z], -1), np.stack([z, z, o], -1)], -2)
    dR = np.stack([np.stack([-s, c, z], -1), np.stack([-c, -s, z], -1), np.stack([z, z, z], -1)], -2)
    return R, dR


def satellite_states_at_reception(ephs, t_gpst_s, r_rx_e_m, iters=4):
    """Light-time iteration for the satellites ``ephs`` (BroadcastEphemeris) and
    a receiver at ECEF ``r_rx_e_m`` [m] at true reception time ``t_gpst_s``.

    Returns r_sat (N,3) and v_sat (N,3) at t_tx in ECEF(t_tx), satellite clock
    bias [s] (incl. relativity, TGD *not* applied) and drift [s/s], tau [s] (N,),
    and the Sagnac rotation R3(we tau) (N,3,3) with its time derivative
    we dR3/dtheta (N,3,3)."""
    n = len(ephs)
    r = np.empty((n, 3))
    v = np.empty((n, 3))
    cb, cd, tau = np.empty(n), np.empty(n), np.full(n, 0.075)
    we = np.empty(n)
    r_rx = np.asarray(r_rx_e_m, float)
    groups: dict = {}
    for k, e in enumerate(ephs):                 # one pass per system and orbit kind, all satellites at once
        groups.setdefault((e.system, e.is_geo), []).append(k)
    for (system, _), idx in groups.items():
        stack = EphemerisStack([ephs[k] for k in idx])
        w = constants(system)[1]
        t_sys = np.full(len(idx), system_time_s(system, t_gpst_s))
        tau_g = tau[idx]
        for _ in range(iters):
            r_g = satellite_position_ecef(stack, t_sys, -tau_g)[0]
            R, _ = rot3(w * tau_g)
            tau_g = np.linalg.norm(np.einsum("nij,nj->ni", R, r_g) - r_rx, axis=1) / C_MPS
        r[idx], v[idx], cb[idx], cd[idx] = satellite_position_ecef(stack, t_sys, -tau_g)
        tau[idx], we[idx] = tau_g, w
    R, dR = rot3(we * tau)
    return r, v, cb, cd, tau, R, dR * we[:, None, None]
