"""The receiver's aiding input: the fusion node's navigation state (position,
velocity, attitude, specific force and their covariance, ``nav/state``)
checked, held and predicted to the receiver's epochs (issue 23, "closing the
loop in the graph"). Pure Python; ``gnss_node`` converts messages into
:class:`AidingSample` and asks :class:`AidingInput` for a prediction.

Prediction (Groves 2nd ed. sec. 5.3 and 15.3, ECEF mechanization over the short
interval dt = t - t_state, the aiding's latency): with C_n_e at the state's
position, r_e = geodetic_to_ecef(lat, lon, alt), v_e = C_n_e v_enu,
a_e = C_n_e (C_b_n f_b + g_n) - 2 Omega_ie x v_e  (g_n normal gravity,
which holds the centrifugal term), then r_e(t) = r_e + v_e dt + a_e dt^2 / 2,
v_e(t) = v_e + a_e dt. Covariance: the state's ENU position and velocity
blocks (rotated to ECEF), the position grown by the velocity covariance over
dt (P_r + P_v dt^2; cross terms left out) and both by
``accel_sigma_mps2`` (the unmodelled acceleration over dt).

The receiver's predicted Doppler for a satellite with unit line of sight
u_e (antenna to satellite) is -(u . (v_sat - v_hat))/lambda - d_clk_hat/lambda;
the loop's input is the true Doppler minus it, i.e. (u . (v_a - v_hat) -
(d_clk - d_clk_hat))/lambda: :func:`doppler_residual_hz`. The simulator
evaluates it with its truth antenna velocity (the world); the receiver knows
only v_hat and its covariance.

Bad input is never used and is counted (``counts``): non-finite values
(``rejected_nan``), a covariance that is not symmetric positive semidefinite or
lacks the vel/pos blocks (``rejected_cov``), a stamp older than the sample held
(``rejected_out_of_order``). A held state older than ``max_age_s`` at the
epoch is stale: no prediction (``stale_epochs``), the receiver runs unaided.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from hyper_nav_gnss import earth
from hyper_nav_gnss.constants import C_MPS

OMEGA_IE_RADPS = 7.292115e-5


@dataclass
class AidingSample:
    """One navigation state as the fusion node publishes it (``nav/state``)."""
    t_s: float
    lat_rad: float
    lon_rad: float
    alt_m: float
    vel_enu_mps: np.ndarray
    q_b_enu_xyzw: np.ndarray
    accel_b_mps2: np.ndarray
    state_blocks: list
    covariance: np.ndarray          # (state_dim, state_dim)


@dataclass
class AidingPrediction:
    t_s: float
    age_s: float
    r_e_m: np.ndarray
    v_e_mps: np.ndarray
    P_pos_e_m2: np.ndarray
    P_vel_e_m2ps2: np.ndarray


def _block_slices(blocks):
    out, i = {}, 0
    for b in blocks:
        name, _, n = str(b).partition(":")
        n = int(n)
        out[name] = slice(i, i + n)
        i += n
    return out, i


@dataclass
class AidingInput:
    """Latest accepted navigation state and the counters of what was refused."""
    max_age_s: float = 1.0
    accel_sigma_mps2: float = 0.5
    counts: dict = field(default_factory=lambda: {"accepted": 0, "rejected_nan": 0, "rejected_cov": 0,
                                                  "rejected_out_of_order": 0, "stale_epochs": 0,
                                                  "aided_epochs": 0})
    held: AidingSample | None = None
    age_sum_s: float = 0.0          # sum of the ages of the states used (mean: / aided_epochs)
    _P_pos: np.ndarray | None = None
    _P_vel: np.ndarray | None = None

    def offer(self, s: AidingSample) -> bool:
        """Check and hold ``s``; False (and counted) if refused."""
        vals = np.concatenate([[s.t_s, s.lat_rad, s.lon_rad, s.alt_m], np.ravel(s.vel_enu_mps),
                               np.ravel(s.q_b_enu_xyzw), np.ravel(s.accel_b_mps2)])
        cov = np.asarray(s.covariance, float)
        if not np.all(np.isfinite(vals)) or not np.all(np.isfinite(cov)):
            self.counts["rejected_nan"] += 1
            return False
        try:
            sl, dim = _block_slices(s.state_blocks)
        except ValueError:
            sl, dim = {}, -1
        if "vel" not in sl or "pos" not in sl or cov.shape != (dim, dim):
            self.counts["rejected_cov"] += 1
            return False
        P = cov[np.r_[sl["pos"], sl["vel"]]][:, np.r_[sl["pos"], sl["vel"]]]
        scale = max(1.0, float(np.max(np.abs(P))))
        if np.max(np.abs(P - P.T)) > 1e-9 * scale or np.linalg.eigvalsh(0.5 * (P + P.T)).min() < -1e-9 * scale:
            self.counts["rejected_cov"] += 1
            return False
        if self.held is not None and s.t_s < self.held.t_s:
            self.counts["rejected_out_of_order"] += 1
            return False
        self.held = s
        self._P_pos, self._P_vel = P[:3, :3], P[3:, 3:]
        self.counts["accepted"] += 1
        return True

    def predict(self, t_s: float) -> AidingPrediction | None:
        """State predicted to t_s, or None (counted stale) without a fresh state."""
        s = self.held
        if s is None or not (-self.max_age_s <= t_s - s.t_s <= self.max_age_s):
            self.counts["stale_epochs"] += 1
            return None
        dt = t_s - s.t_s
        Cne = earth.C_n_e(s.lat_rad, s.lon_rad)
        r = np.asarray(earth.geodetic_to_ecef(s.lat_rad, s.lon_rad, s.alt_m), float).reshape(3)
        v = Cne @ np.asarray(s.vel_enu_mps, float)
        C_b_n = Rotation.from_quat(np.asarray(s.q_b_enu_xyzw, float)).as_matrix()     # (x, y, z, w)
        g_n = np.asarray(earth.gravity_n(s.lat_rad, s.alt_m), float).reshape(3)
        a = Cne @ (C_b_n @ np.asarray(s.accel_b_mps2, float) + g_n) - 2.0 * np.cross([0.0, 0.0, OMEGA_IE_RADPS], v)
        qa = (self.accel_sigma_mps2 * dt) ** 2
        P_v = Cne @ self._P_vel @ Cne.T + qa * np.eye(3)
        P_r = Cne @ (self._P_pos + self._P_vel * dt * dt) @ Cne.T + 0.25 * qa * dt * dt * np.eye(3)
        self.counts["aided_epochs"] += 1
        self.age_sum_s += dt
        return AidingPrediction(t_s, dt, r + v * dt + 0.5 * a * dt * dt, v + a * dt, P_r, P_v)


def doppler_residual_hz(pred: AidingPrediction, u_e, v_a_e_mps, clk_drift_err_mps, carrier_hz):
    """Doppler the aided loop must follow [Hz] per satellite: (u . (v_a - v_hat)
    - clock-drift error) / lambda (module docstring); u_e (n, 3) antenna to satellite."""
    lam = C_MPS / np.asarray(carrier_hz, float)
    return (np.asarray(u_e, float) @ (np.asarray(v_a_e_mps, float) - pred.v_e_mps) - clk_drift_err_mps) / lam


def los_sigmas(pred: AidingPrediction, u_e, clk_drift_sigma_mps, clk_bias_sigma_m):
    """(line-of-sight velocity sigma [m/s], range sigma [m]) per satellite of the prediction."""
    u = np.asarray(u_e, float)
    s_v = np.sqrt(np.einsum("ki,ij,kj->k", u, pred.P_vel_e_m2ps2, u) + clk_drift_sigma_mps ** 2)
    s_r = np.sqrt(np.einsum("ki,ij,kj->k", u, pred.P_pos_e_m2, u) + clk_bias_sigma_m ** 2)
    return s_v, s_r


__all__ = ["AidingSample", "AidingPrediction", "AidingInput", "doppler_residual_hz", "los_sigmas"]
