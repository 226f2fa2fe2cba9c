"""Single-epoch weighted least-squares PVT from pseudoranges and pseudorange rates.

Position/clock (Gauss-Newton): unknowns [x, y, z (ECEF m), b_ref (m), isb_k (m)
for every further system], model
    rho + c dt_sat - I - T = |R3(we tau) r_sat(t_tx) - r| + b_ref + isb_sys,
with t_tx = t_tag - rho/c - dt_sat (exact from the receiver time tag, since
rho already contains the receiver clock), tau = geometric light time (Sagnac).
The fix refers to true time t_tag - b_ref/c.
Velocity/drift (linear): unknowns [vx, vy, vz (m/s), d (m/s)],
    rho_dot + c dt_sat_dot = u.(R3 v_sat - v)/g + d,  g as in :mod:`observables`.
Weights 1/sigma^2; the normal-equation steps, covariance (H^T W H)^-1 (scaled
by nothing: a-priori sigmas) and clock columns are :mod:`.least_squares`
(shared with :mod:`.spp`); DOPs (:mod:`.dop`) from the unweighted geometry,
position part rotated to ENU. A singular geometry raises
``numpy.linalg.LinAlgError``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_gnss.orbits.ephemeris import C_MPS, constants, satellite_position_ecef, system_time_s
from hyper_nav_gnss.geometry import rot3
from hyper_nav_gnss.positioning.dop import dops
from hyper_nav_gnss.positioning.least_squares import clock_columns, covariance, solve_linear, solve_step


@dataclass
class PvtSolution:
    r_e_m: np.ndarray            # ECEF position [m] at true time t_tag - clk_bias/c
    clk_bias_m: float            # reference-system receiver clock [m]
    isb_m: dict                  # inter-system bias per non-reference system [m]
    cov_pos_clk: np.ndarray      # covariance of [x, y, z, b, isb...]
    v_e_mps: np.ndarray | None   # ECEF velocity [m/s]
    clk_drift_mps: float | None
    cov_vel_drift: np.ndarray | None
    dop: dict                    # gdop, pdop, hdop, vdop, tdop (:mod:`.dop`)
    residuals_m: np.ndarray
    residuals_rate_mps: np.ndarray | None
    iterations: int
    ref_system: str


def _sat_geometry(ephs, t_tag_s, pr_m, r_rx, clk_bias_m):
    n = len(ephs)
    rr, vr = np.empty((n, 3)), np.empty((n, 3))
    dts, dtd, dR_r = np.empty(n), np.empty(n), np.empty((n, 3))
    for k, e in enumerate(ephs):
        we = constants(e.system)[1]
        t_sys = system_time_s(e.system, t_tag_s)
        _, _, cb, _ = satellite_position_ecef(e, t_sys, -pr_m[k] / C_MPS)
        r_s, v_s, dts[k], dtd[k] = satellite_position_ecef(e, t_sys, -pr_m[k] / C_MPS - (cb - e.tgd))
        # true reception time = t_tag - b/c; geometric light time:
        tau = (pr_m[k] - clk_bias_m) / C_MPS + cb - e.tgd
        R, dR = rot3(np.array(we * tau))
        rr[k], vr[k], dR_r[k] = R @ r_s, R @ v_s, we * (dR @ r_s)
    return rr, vr, dts, dtd, dR_r


def solve_pvt(ephs, t_tag_s, pseudorange_m, pr_sigma_m=None, pseudorange_rate_mps=None,
              rate_sigma_mps=None, iono_m=None, tropo_m=None, r0_e_m=None, max_iter=10,
              tol_m=1e-5) -> PvtSolution:
    """WLS fix. Inputs are per-satellite arrays in the order of ``ephs``;
    ``t_tag_s`` the receiver time tag (continuous GPST); iono/tropo [m] are
    subtracted if given; TGD/TGD1 is applied (single-frequency L1 C/A / B1I)."""
    pr = np.asarray(pseudorange_m, float)
    n = pr.size
    w = 1.0 / np.asarray(pr_sigma_m if pr_sigma_m is not None else np.ones(n), float) ** 2
    corr = np.zeros(n)
    if iono_m is not None:
        corr += iono_m
    if tropo_m is not None:
        corr += tropo_m
    systems = [s for s in ("G", "C") if any(e.system == s for e in ephs)]
    ref = systems[0]
    tgd = np.array([e.tgd for e in ephs])
    ncol = 4 + len(systems) - 1
    if n < ncol:
        raise ValueError(f"{n} pseudoranges for {ncol} unknowns")
    clk_cols = clock_columns([e.system for e in ephs], systems)
    isb_cols = clk_cols[:, 1:]
    x = np.zeros(ncol)
    x[:3] = r0_e_m if r0_e_m is not None else 0.0
    it = 0
    for it in range(1, max_iter + 1):
        rr, vr, dts, dtd, dR_r = _sat_geometry(ephs, t_tag_s, pr, x[:3], x[3])
        d = rr - x[:3]
        rho = np.linalg.norm(d, axis=1)
        u = d / rho[:, None]
        pred = rho + x[3] + isb_cols @ x[4:]
        y = pr + C_MPS * (dts - tgd) - corr
        H = np.hstack([-u, clk_cols])
        step = solve_step(H, y - pred, w)
        if step is None:
            raise np.linalg.LinAlgError(f"singular PVT geometry ({n} satellites, {ncol} unknowns)")
        dx = step[0]
        x = x + dx
        if np.linalg.norm(dx[:3]) < tol_m and it > 1:
            break
    rr, vr, dts, dtd, dR_r = _sat_geometry(ephs, t_tag_s, pr, x[:3], x[3])
    d = rr - x[:3]
    rho = np.linalg.norm(d, axis=1)
    u = d / rho[:, None]
    H = np.hstack([-u, clk_cols])
    res = pr + C_MPS * (dts - tgd) - corr - (rho + x[3] + isb_cols @ x[4:])
    cov = covariance(H, w)
    if cov is None:
        raise np.linalg.LinAlgError(f"singular PVT geometry ({n} satellites, {ncol} unknowns)")
    # DOPs (unweighted, single clock column)
    G = np.hstack([-u, np.ones((n, 1))])
    lat, lon, _ = earth.ecef_to_geodetic(x[:3])
    dop = dops(G, lat, lon)
    v = drift = cov_v = res_v = None
    if pseudorange_rate_mps is not None:
        prr = np.asarray(pseudorange_rate_mps, float)
        wv = 1.0 / np.asarray(rate_sigma_mps if rate_sigma_mps is not None else np.ones(n), float) ** 2
        g = 1.0 - np.einsum("ki,ki->k", u, dR_r - vr) / C_MPS
        Hv = np.hstack([-u / g[:, None], np.ones((n, 1))])
        yv = prr + C_MPS * dtd - np.einsum("ki,ki->k", u, vr) / g
        lin = solve_linear(Hv, yv, wv)
        if lin is None:
            raise np.linalg.LinAlgError(f"singular PVT velocity geometry ({n} satellites)")
        xv, cov_v, res_v = lin
        v, drift = xv[:3], float(xv[3])
    return PvtSolution(x[:3], float(x[3]), {s: float(x[4 + j]) for j, s in enumerate(systems[1:])}, cov,
                       v, drift, cov_v, dop, res, res_v, it, ref)
