"""Launch-centred inertial mechanization frame (seed 001): nominal state
r_a (m, from the LCI origin), inertial velocity v_a (m/s) and C_b_a.

Nominal vector (``X_*``, 15 entries): r_a (3), v_a (3), C_b_a (row-major, 9).
Mechanization: ``core.lci.mechanization`` (one-plus-previous two-sample
coning/sculling/scrolling, eqs. 16-64) with the gravitation of
``lci_gravity`` (J2 by default, eqs. 7-10).

Error dynamics of att/vel/pos in LCI axes (a is inertial: no Earth or
transport rate terms; eqs. 79-86, errors estimate minus truth):
    phi_dot = (block couplings through C_b_a)
    dv_dot  = (C_b_a f_b) x phi + G_a dr            (+ block couplings)
    dr_dot  = dv
with G_a = dg_a/dr_a the gravity gradient (``gravity.gravity_gradient_a``).
Measurement models are written in the ENU convention; ``to_enu`` maps this
frame's att/vel/pos errors into it. With dr_n = C_a_n dr_a, a position error
also turns the local ENU frame by dtheta_n = M dr_n (M: east -> rotation about
north by dE/(R_N+h) and about up by dE tan(lat)/(R_N+h), north -> about east
by -dN/(R_M+h)), which the ENU convention's attitude and velocity errors
contain:
    phi_n = C_a_n phi_a + M dr_n,
    dv_n  = C_a_n (dv_a - omega_ie_a x dr_a) + [v_n x] M dr_n
(v_a is inertial, the ENU velocity is Earth-relative).
The launch frame: launch point = the initial position, launch epoch t0 = the
initial time, azimuth ``cfg.launch_azimuth_deg``.
"""
from __future__ import annotations

import numpy as np

from hyper_nav_gnss import earth
from ..attitude import attitude_error_n_rad, orthonormalize, rotvec_to_C, skew
from ..lci.frames import OMEGA_IE_RADPS, LaunchFrame
from ..lci.gravity import gravity_gradient_a, make_gravity
from ..lci.mechanization import increments_one_plus_previous
from ..fast import lci as fast_lci
from ..fast.predict import imu_terms as fast_predict_terms
from ..nav_state import NavState

X_R, X_V, X_C = slice(0, 3), slice(3, 6), slice(6, 15)
NOMINAL_SIZE = 15
_I3 = np.eye(3)



class LciFrame:
    name = "LCI"
    compiled_runs = False    # core.fusion_run: no compiled run (samples go one by one)
    nominal_size = NOMINAL_SIZE

    def __init__(self, cfg, initial: NavState, launch: LaunchFrame | None = None):
        self.launch = launch or LaunchFrame(float(initial.lat_rad), float(initial.lon_rad), float(initial.alt_m),
                                            np.deg2rad(cfg.launch_azimuth_deg), float(initial.t_s))
        self.gravity = make_gravity(cfg.lci_gravity, self.launch)
        self._normal_gravity = cfg.lci_gravity == "normal"
        self._cache_key = None
        self._cache = None
        self.fast = True              # the compiled geodetic view (the filter sets it: ErrorStateKF.fast)

    # ---- nominal state <-> geodetic/ENU view ------------------------------------
    def nominal(self, nav: NavState) -> np.ndarray:
        r_a, v_a, C_b_a = self.launch.geodetic_to_lci(nav.lat_rad, nav.lon_rad, nav.alt_m, nav.vel_enu_mps,
                                                      nav.C_b_n, nav.t_s)
        x = np.empty(NOMINAL_SIZE)
        x[X_R], x[X_V], x[X_C] = r_a, v_a, np.asarray(C_b_a, float).ravel()
        return x

    def _geodetic(self, x, t_s):
        """(lat, lon, alt, vel_enu, C_b_n, C_n_a), cached for the last vector (runs every epoch)."""
        if self._cache_key is not None and self._cache_key[0] is x and self._cache_key[1] == t_s:
            return self._cache
        L = self.launch
        if self.fast:
            out = fast_lci.geodetic(x, float(t_s - L.t0_s), L.C_t_a, L.R0_a_m)
            self._cache_key, self._cache = (x, t_s), out
            return out
        ang = OMEGA_IE_RADPS * (t_s - L.t0_s)
        c, sn = np.cos(ang), np.sin(ang)
        C_e_a = L.C_t_a @ np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
        r_e = C_e_a.T @ (x[X_R] + L.R0_a_m)
        v_e = C_e_a.T @ x[X_V] - np.array([-OMEGA_IE_RADPS * r_e[1], OMEGA_IE_RADPS * r_e[0], 0.0])
        lat, lon, alt = earth.ecef_to_geodetic(r_e)
        C_n_e = earth.C_n_e(lat, lon)
        C_n_a = C_e_a @ C_n_e
        out = (float(lat), float(lon), float(alt), C_n_e.T @ v_e, C_n_a.T @ x[X_C].reshape(3, 3), C_n_a)
        self._cache_key, self._cache = (x, t_s), out
        return out

    def view(self, x, t_s: float):
        lat, lon, alt, v, C, _ = self._geodetic(x, t_s)
        return lat, lon, alt, v.copy(), C.copy()

    def to_enu(self, x, t_s: float) -> np.ndarray:
        """9 x 9 transform of att/vel/pos errors LCI -> ENU convention."""
        lat, _, alt, v_n, _, C_n_a = self._geodetic(x, t_s)
        Ct = C_n_a.T
        r_m, r_n = earth.radii(lat)
        M = np.array([[0.0, -1.0 / (r_m + alt), 0.0],
                      [1.0 / (r_n + alt), 0.0, 0.0],
                      [np.tan(lat) / (r_n + alt), 0.0, 0.0]]) @ Ct
        T = np.zeros((9, 9))
        T[0:3, 0:3] = Ct
        T[0:3, 6:9] = M
        T[3:6, 3:6] = Ct
        T[3:6, 6:9] = -Ct @ skew(self.launch.omega_ie_a_radps) + skew(v_n) @ M
        T[6:9, 6:9] = Ct
        return T

    def C_b_x(self, x) -> np.ndarray:
        return x[X_C].reshape(3, 3)

    # ---- mechanization ---------------------------------------------------------------
    def mechanize(self, x, t_s, dth, dv, dth_p, dv_p, dt_s, dt_p_s=None) -> np.ndarray:
        """Eq. 6 over one interval: attitude, velocity, position from the body
        increments, gravitation at the mid-interval extrapolated position.
        ``dt_p_s`` (the previous interval) is not used: this frame's
        correction terms assume equal intervals (the ENU frame weights them,
        ``mechanization.two_sample_divisor``)."""
        inc = increments_one_plus_previous(dth, dv, dth_p, dv_p, dt_s)
        C0, v0, r0 = x[X_C].reshape(3, 3), x[X_V], x[X_R]
        g_mid = self.gravity(r0 + 0.5 * dt_s * v0, t_s + 0.5 * dt_s)
        out = np.empty(NOMINAL_SIZE)
        out[X_V] = v0 + C0 @ inc.dv_sf_b_mps + g_mid * dt_s
        out[X_R] = r0 + v0 * dt_s + C0 @ inc.dr_sf_b_m + g_mid * (0.5 * dt_s * dt_s)
        out[X_C] = orthonormalize(C0 @ rotvec_to_C(inc.phi_b_rad)).ravel()
        return out

    def mechanize_nominal(self, x, t_s, vals, imu, prev, sm) -> np.ndarray:
        """The nominal half of ``fast_predict`` (no covariance), for the output
        predictor: the raw increments corrected with the block values ``vals``
        (the compiled correction) and ``mechanize``d."""
        p = imu if prev is None else prev
        th, v, th_p, v_p, _, _, _ = fast_predict_terms(imu.dtheta_b_rad, imu.dvel_b_mps, float(imu.dt_s),
                                                       p.dtheta_b_rad, p.dvel_b_mps, float(p.dt_s), prev is not None,
                                                       vals, *sm.roles_args)
        if prev is None:
            th_p = v_p = None
        return self.mechanize(x, t_s, th, v, th_p, v_p, imu.dt_s)

    def bridge(self, x, t_s, omega_b, f_b, dt_s) -> np.ndarray:
        return self.mechanize(x, t_s, omega_b * dt_s, f_b * dt_s, None, None, dt_s)

    # ---- compiled predict (core.fast) -----------------------------------------------------
    def fast_predict(self, x, t_s, vals, P, imu, prev, sm):
        """One predict step in compiled form (core.fast.lci): (new nominal vector, P', Phi).
        The increments are passed as they are (float64 arrays; the engine makes them so)."""
        out = np.empty(NOMINAL_SIZE)
        L = self.launch
        p = imu if prev is None else prev            # fixed argument types: one compiled signature
        P1, Phi = fast_lci.predict(x, float(t_s - L.t0_s), vals, P, imu.dtheta_b_rad, imu.dvel_b_mps, float(imu.dt_s),
                                   p.dtheta_b_rad, p.dvel_b_mps, float(p.dt_s), prev is not None, *sm.fast_args,
                                   L.R0_a_m, L.spin_axis_a, L.C_t_a, self._normal_gravity, out)
        return out, P1, Phi

    # ---- error model ------------------------------------------------------------------
    def error_dynamics(self, x, t_s, f_b_mps2, omega_ib_b_radps):
        C = x[X_C].reshape(3, 3)
        F = np.zeros((9, 9))
        F[3:6, 0:3] = skew(C @ f_b_mps2)
        F[3:6, 6:9] = gravity_gradient_a(x[X_R], self.launch)
        F[6:9, 3:6] = _I3
        return F, C

    def difference(self, x_est, x_true) -> np.ndarray:
        """The att/vel/pos error (estimate - truth) in LCI axes (inverse of ``inject``)."""
        phi = attitude_error_n_rad(x_est[X_C].reshape(3, 3), x_true[X_C].reshape(3, 3))
        return np.concatenate([phi, x_est[X_V] - x_true[X_V], x_est[X_R] - x_true[X_R]])

    def feed_back(self, x, x_then, x_anchor, S, S_then, gains):
        """The complementary output predictor's correction: gains * (the
        difference at the anchor's stamp less what was fed back since) taken
        off x; (x, S + c)."""
        c = np.repeat(gains, 3) * (self.small_difference(x_then, x_anchor) - (S - S_then))
        return self.fast_inject(x, c), S + c

    def small_difference(self, x_est, x_true) -> np.ndarray:
        """``difference`` (the output predictor's feedback; no compiled form here)."""
        return self.difference(x_est, x_true)

    def fast_inject(self, x, dx9) -> np.ndarray:
        """``inject`` in compiled form (core.fast.lci)."""
        return fast_lci.inject(x, dx9)

    def inject(self, x, dx9) -> np.ndarray:
        out = np.empty(NOMINAL_SIZE)
        out[X_C] = (rotvec_to_C(dx9[0:3]) @ x[X_C].reshape(3, 3)).ravel()   # C_true = (I + [phi x]) C_est
        out[X_V] = x[X_V] - dx9[3:6]
        out[X_R] = x[X_R] - dx9[6:9]
        return out
