"""Alpha-beta tracker of the vehicle position for short-interval extrapolation
(seed 004 section 2.3, eq. 10: "[x_e y_e z_e] is the approximate vehicle
position extrapolated over a short interval by an alpha-beta filter").

Per ECEF axis, constant-velocity model, fixed steady-state gains from the
tracking index lambda = sigma_a T^2 / sigma_z (Kalata, "The tracking index:
a generalized parameter for alpha-beta and alpha-beta-gamma target
trackers", IEEE Trans. AES 20(2), 1984):

    alpha = -(lambda^2 + 8 lambda - (lambda + 4) sqrt(lambda^2 + 8 lambda)) / 8
    beta  = (lambda^2 + 4 lambda - lambda sqrt(lambda^2 + 8 lambda)) / 4

with sigma_a the white acceleration the vehicle may do (``accel_sigma_mps2``)
and sigma_z the fix noise. Between fixes (and after the last one, through
the whole outage) the position is extrapolated as r + v dt; its uncertainty
grows like the steady-state covariance plus sigma_a^2 dt^4 / 4 (a constant
unknown acceleration over the extrapolation), used when the virtual
pseudoranges carry a consistent covariance.
"""
from __future__ import annotations

import numpy as np


def kalata_gains(tracking_index: float) -> tuple[float, float]:
    """Steady-state (alpha, beta) of the alpha-beta filter for a tracking index."""
    lam = float(tracking_index)
    r = np.sqrt(lam ** 2 + 8.0 * lam)
    return -(lam ** 2 + 8.0 * lam - (lam + 4.0) * r) / 8.0, (lam ** 2 + 4.0 * lam - lam * r) / 4.0


class AlphaBetaTracker:
    """ECEF position/velocity tracker fed with receiver fixes (m) at epochs t (s)."""

    def __init__(self, accel_sigma_mps2: float, fix_sigma_m: float, period_s: float):
        self.accel_sigma = float(accel_sigma_mps2)
        self.fix_sigma = float(fix_sigma_m)
        self.period = float(period_s)
        self.alpha, self.beta = kalata_gains(self.accel_sigma * self.period ** 2 / self.fix_sigma)
        self.t_s: float | None = None
        self.r_e_m = np.zeros(3)
        self.v_e_mps = np.zeros(3)
        self._v_known = False
        self.n_updates = 0

    def update(self, t_s: float, r_fix_e_m, v_fix_e_mps=None) -> None:
        """One fix at t_s (ascending). The first fix initialises the position
        (and the velocity from ``v_fix_e_mps`` if given, else the second fix
        does, by the difference), later ones correct the prediction with the
        alpha-beta gains."""
        r = np.asarray(r_fix_e_m, float)
        if self.t_s is None:
            self.r_e_m = r.copy()
            self._v_known = v_fix_e_mps is not None
            self.v_e_mps = np.zeros(3) if v_fix_e_mps is None else np.asarray(v_fix_e_mps, float).copy()
        else:
            dt = t_s - self.t_s
            if dt <= 0.0:
                return
            if not self._v_known:
                self.v_e_mps, self.r_e_m, self._v_known = (r - self.r_e_m) / dt, r.copy(), True
                self.t_s = float(t_s)
                self.n_updates += 1
                return
            pred = self.r_e_m + self.v_e_mps * dt
            res = r - pred
            self.r_e_m = pred + self.alpha * res
            self.v_e_mps = self.v_e_mps + self.beta / dt * res
        self.t_s = float(t_s)
        self.n_updates += 1

    def predict(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Extrapolated (position, velocity) at t_s (constant velocity)."""
        if self.t_s is None:
            raise ValueError("alpha-beta tracker: no fix yet")
        return self.r_e_m + self.v_e_mps * (t_s - self.t_s), self.v_e_mps.copy()

    def position_sigma_m(self, t_s: float) -> float:
        """1-sigma per-axis position uncertainty of :meth:`predict` at t_s:
        steady-state filter position error (alpha sigma_z) plus the velocity
        error (beta sigma_z / T) and an unknown acceleration over the gap."""
        dt = max(t_s - (self.t_s if self.t_s is not None else t_s), 0.0)
        s_r = self.alpha * self.fix_sigma
        s_v = self.beta * self.fix_sigma / self.period
        return float(np.sqrt(s_r ** 2 + (s_v * dt) ** 2 + (0.5 * self.accel_sigma * dt ** 2) ** 2))
