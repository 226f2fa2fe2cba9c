"""Tightly coupled GNSS: pseudorange and pseudorange-rate models (seed 004
eq. 7) for the ESKF with a receiver clock block ``clk`` = [bias m, drift m/s].

    rho_j      = |r_j - r_a| + b + eps          (Sagnac-corrected geometry)
    rho_dot_j  = u_j . (v_j - v_a) ... written as -u_j^T (v_a - v_j) + d

with r_a the antenna position (ECEF), u_j the unit line of sight from the
satellite to the antenna. Satellite positions/velocities come from the
broadcast ephemeris at the transmit time, already corrected for satellite
clock, ionosphere and troposphere by the caller (``corrected_*`` fields).
Residuals are predicted minus measured; H rows are in the ENU error state.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_gnss import earth
from .attitude import skew
from .measurements import Measurement
from .nav_state import NavState
from .state_layout import StateLayout

from hyper_nav_gnss.constants import C_MPS


def sagnac_rotate(r_sat_e_m: np.ndarray, transit_s: np.ndarray) -> np.ndarray:
    """Rotate satellite positions by the Earth rotation during signal transit."""
    theta = earth.OMEGA_IE_RADPS * transit_s
    c, s = np.cos(theta), np.sin(theta)
    x, y = r_sat_e_m[:, 0], r_sat_e_m[:, 1]
    return np.stack([c * x + s * y, -s * x + c * y, r_sat_e_m[:, 2]], axis=1)


@dataclass(frozen=True)
class Pseudoranges(Measurement):
    """Per-satellite corrected pseudoranges (m) and rates (m/s) at epoch t_s.
    ``rate_mps`` may be empty when only code is used.

    Optional range-error states (``blocks.range_bias``): ``isb_col`` per
    satellite the column of its system in the ``isb`` block (-1: GPS, the
    clock's own system), ``bias_slot`` its slot in the range-bias block
    ``bias_block`` (-1: none); then rho_j = |r_j - r_a| + b + isb_s(j) + b_slot(j)."""
    t_s: float
    sat_pos_e_m: np.ndarray
    sat_vel_e_mps: np.ndarray
    pseudorange_m: np.ndarray
    pseudorange_var_m2: np.ndarray
    rate_mps: np.ndarray
    rate_var_m2ps2: np.ndarray
    kind: str = "pseudorange"
    isb_col: np.ndarray | None = None
    bias_slot: np.ndarray | None = None
    bias_block: str = ""
    coupling = "tight"

    def model(self, state: NavState, layout: StateLayout, ctx):
        if not layout.has("clk"):
            raise ValueError("pseudorange updates need the 'clk' state block")
        clk = state.extra.get("clk", np.zeros(2))
        C_n_e = earth.C_n_e(state.lat_rad, state.lon_rad)
        l_n = state.C_b_n @ ctx.lever_arm_b_m
        r_a = earth.geodetic_to_ecef(state.lat_rad, state.lon_rad, state.alt_m) + C_n_e @ (
            l_n + state.vel_enu_mps * ctx.dt_to_meas_s)
        v_a = C_n_e @ state.vel_enu_mps                 # w.r.t. ECEF, ECEF axes
        rng = np.linalg.norm(self.sat_pos_e_m - r_a, axis=1)
        r_sat = sagnac_rotate(self.sat_pos_e_m, rng / C_MPS)
        los = r_a - r_sat
        rng = np.linalg.norm(los, axis=1)
        u_e = los / rng[:, None]                    # satellite -> antenna
        u_n = u_e @ C_n_e                            # rows in ENU
        n = len(rng)
        ck = layout.sl("clk")
        p, v, a = layout.sl("pos"), layout.sl("vel"), layout.sl("att")
        H_rho = np.zeros((n, layout.dim))
        H_rho[:, p] = u_n
        H_rho[:, a] = u_n @ skew(l_n)
        H_rho[:, ck.start] = 1.0
        res_rho = rng + clk[0] - self.pseudorange_m
        for block, cols in (("isb", self.isb_col), (self.bias_block, self.bias_slot)):
            if cols is None or not block or not layout.has(block):
                continue
            cols = np.asarray(cols, int)
            rows = np.flatnonzero(cols >= 0)
            if len(rows):
                res_rho = res_rho + np.where(cols >= 0, np.asarray(state.extra.get(block), float)[np.maximum(cols, 0)],
                                             0.0)
                H_rho[rows, layout.sl(block).start + cols[rows]] = 1.0
        res = [res_rho]
        H = [H_rho]
        R = [self.pseudorange_var_m2]
        if len(self.rate_mps):
            v_sat = sagnac_rotate(self.sat_vel_e_mps, rng / C_MPS)
            w = v_a - v_sat
            u_dot_w = np.einsum("ij,ij->i", u_e, w)
            rate_pred = u_dot_w + clk[1]
            H_rate = np.zeros((n, layout.dim))
            H_rate[:, v] = u_n
            # the line of sight turns with the position: d(u.w)/dr = w^T (I - u u^T) / rho
            H_rate[:, p] = ((w - u_e * u_dot_w[:, None]) / rng[:, None]) @ C_n_e
            H_rate[:, ck.start + 1] = 1.0
            res.append(rate_pred - self.rate_mps)
            H.append(H_rate)
            R.append(self.rate_var_m2ps2)
        return np.concatenate(res), np.vstack(H), np.diag(np.concatenate(R))
