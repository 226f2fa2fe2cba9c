"""Local-level mechanization frame: nominal state in geodetic position, ENU
velocity w.r.t. Earth and C_b_n; the filter's reference error convention
(outputs and measurement models are written in it, so its transform is the
identity).

Nominal vector (``X_*`` indices, 18 entries): lat, lon (rad), alt (m),
vel_enu (m/s, 3), C_b_n (row-major, 9), and the previous epoch's velocity
(3, for the mid-interval extrapolation of ``mechanization.step``).

Error dynamics of att/vel/pos, phi-angle model (Titterton & Weston ch. 12;
seed 003 eqs. 20-21; seed 001's 15-state model written in ENU):

    phi_dot = -omega_in_n x phi + d_omega_in_n          (+ block couplings, C_b_n)
    dv_dot  =  f_n x phi - (2 omega_ie_n + omega_en_n) x dv
               + v_n x (2 d_omega_ie_n + d_omega_en_n) + d_g_n
    dr_dot  =  dv + (curvature terms of order v/R)
with errors estimate minus truth and the position error in local ENU metres.
"""
from __future__ import annotations

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_filter.core import mechanization
from ..fast import enu as fast_enu
from ..fast import nominal as fast_nominal
from ..attitude import attitude_error_n_rad, rotvec_to_C, skew
from ..nav_state import NavState

X_LAT, X_LON, X_ALT, X_VEL, X_C, X_VPREV = 0, 1, 2, slice(3, 6), slice(6, 15), slice(15, 18)
NOMINAL_SIZE = 18
_I3 = np.eye(3)



class EnuFrame:
    name = "ENU"
    compiled_runs = True     # core.fusion_run: this frame's predict has a compiled run over IMU arrays
    enu_convention = True    # the error convention is ENU's: to_enu is the identity (None)
    nominal_size = NOMINAL_SIZE

    def __init__(self, cfg, initial: NavState):
        self.fast = True              # (nothing of the view to compile here; ErrorStateKF.fast sets it)

    # ---- nominal state <-> geodetic/ENU view ------------------------------------
    def nominal(self, nav: NavState) -> np.ndarray:
        x = np.empty(NOMINAL_SIZE)
        x[X_LAT], x[X_LON], x[X_ALT] = nav.lat_rad, earth.wrap_lon_rad(nav.lon_rad), nav.alt_m
        x[X_VEL] = nav.vel_enu_mps
        x[X_C] = np.asarray(nav.C_b_n, float).ravel()
        x[X_VPREV] = nav.vel_enu_mps
        return x

    def view(self, x: np.ndarray, t_s: float):
        """(lat, lon, alt, vel_enu, C_b_n) of a nominal vector."""
        return float(x[X_LAT]), float(x[X_LON]), float(x[X_ALT]), x[X_VEL].copy(), x[X_C].reshape(3, 3).copy()

    def view_rows(self, X: np.ndarray) -> dict:
        """``view`` of many nominal vectors at once (rows of X): {"lat", "lon",
        "alt", "vel", "C"} arrays, the same numbers (a reading of the vector)."""
        X = np.asarray(X, float).reshape(-1, NOMINAL_SIZE)
        return {"lat": X[:, X_LAT].copy(), "lon": X[:, X_LON].copy(), "alt": X[:, X_ALT].copy(),
                "vel": X[:, X_VEL].copy(), "C": X[:, X_C].reshape(-1, 3, 3).copy()}

    def to_enu(self, x: np.ndarray, t_s: float):
        """Error transform own -> ENU convention for att/vel/pos: None = identity."""
        return None

    def C_b_x(self, x: np.ndarray) -> np.ndarray:
        return x[X_C].reshape(3, 3)

    # ---- mechanization ---------------------------------------------------------------
    def mechanize(self, x, t_s, dth, dv, dth_p, dv_p, dt_s, dt_p_s=None) -> np.ndarray:
        """Nominal vector at t_s + dt_s from corrected increments (``mechanization.step``);
        ``dt_p_s`` the previous interval (None: equal to dt_s)."""
        if dth_p is None:
            dth_p = dv_p = np.zeros(3)
        lat1, lon1, alt1, v1, C1 = mechanization.step(x[X_LAT], x[X_LON], x[X_ALT], x[X_VEL], x[X_C].reshape(3, 3),
                                                      x[X_VPREV], dth, dv, dth_p, dv_p, dt_s, dt_p_s)
        out = np.empty(NOMINAL_SIZE)
        out[X_LAT], out[X_LON], out[X_ALT] = lat1, lon1, alt1
        out[X_VEL] = v1
        out[X_C] = C1.ravel()
        out[X_VPREV] = x[X_VEL]
        return out

    def bridge(self, x, t_s, omega_b, f_b, dt_s) -> np.ndarray:
        """Propagate over a gap with held corrected rates (no coning/sculling history)."""
        return self.mechanize(x, t_s, omega_b * dt_s, f_b * dt_s, None, None, dt_s)

    # ---- compiled predict (core.fast) -----------------------------------------------------
    def fast_predict(self, x, t_s, vals, P, imu, prev, sm):
        """One predict step in compiled form (core.fast.enu): (new nominal vector, P', Phi).
        The increments are passed as they are (float64 arrays; the engine makes them so)."""
        out = np.empty(NOMINAL_SIZE)
        p = imu if prev is None else prev            # fixed argument types: one compiled signature
        P1, Phi = fast_enu.predict(x, vals, P, imu.dtheta_b_rad, imu.dvel_b_mps, float(imu.dt_s), p.dtheta_b_rad,
                                   p.dvel_b_mps, float(p.dt_s), prev is not None, *sm.fast_args, out)
        return out, P1, Phi

    def mechanize_nominal(self, x, t_s, vals, imu, prev, sm) -> np.ndarray:
        """The nominal half of ``fast_predict`` (no covariance): the raw
        increments corrected with the block values ``vals`` and mechanized
        (core.fast.nominal), for the output predictor."""
        out = np.empty(NOMINAL_SIZE)
        p = imu if prev is None else prev
        fast_nominal.enu_step(x, vals, imu.dtheta_b_rad, imu.dvel_b_mps, float(imu.dt_s), p.dtheta_b_rad,
                              p.dvel_b_mps, float(p.dt_s), prev is not None, *sm.roles_args, out)
        return out

    # ---- error model ------------------------------------------------------------------
    def error_dynamics(self, x, t_s, f_b_mps2, omega_ib_b_radps):
        """(F9, C_b_n): the 9 x 9 att/vel/pos block of F and the body-to-frame rotation."""
        lat, h = x[X_LAT], x[X_ALT]
        v = x[X_VEL]
        ve, vn, vu = v
        C = x[X_C].reshape(3, 3)
        r_m, r_n = earth.radii(lat)
        rmh, rnh = r_m + h, r_n + h
        tl, sl, cl = np.tan(lat), np.sin(lat), np.cos(lat)
        W = earth.OMEGA_IE_RADPS
        w_ie = earth.omega_ie_n(lat)
        w_en = earth.omega_en_n(lat, h, v)
        f_n = C @ f_b_mps2
        # partial derivatives of omega_ie_n and omega_en_n w.r.t. dv and dr (ENU m)
        d_wie_dr = np.zeros((3, 3))
        d_wie_dr[1, 1] = -W * sl / rmh
        d_wie_dr[2, 1] = W * cl / rmh
        d_wen_dv = np.array([[0.0, -1.0 / rmh, 0.0],
                             [1.0 / rnh, 0.0, 0.0],
                             [tl / rnh, 0.0, 0.0]])
        d_wen_dr = np.array([[0.0, 0.0, vn / rmh**2],
                             [0.0, 0.0, -ve / rnh**2],
                             [0.0, ve / (cl**2 * rnh * rmh), -ve * tl / rnh**2]])
        F = np.zeros((9, 9))
        a, vv, p = slice(0, 3), slice(3, 6), slice(6, 9)
        F[a, a] = -skew(w_ie + w_en)
        F[a, vv] = d_wen_dv
        F[a, p] = d_wie_dr + d_wen_dr
        F[vv, a] = skew(f_n)
        F[vv, vv] = -skew(2.0 * w_ie + w_en) + skew(v) @ d_wen_dv
        F[vv, p] = skew(v) @ (2.0 * d_wie_dr + d_wen_dr)
        g = -earth.gravity_n(lat, h)[2]
        F[5, 8] += 2.0 * g / np.sqrt(r_m * r_n)
        F[p, vv] = _I3
        F[p, p] = np.array([[vu / rnh - vn * tl / rmh, ve * tl / rmh, -ve / rnh],
                            [0.0, vu / rmh, -vn / rmh],
                            [0.0, 0.0, 0.0]])
        return F, C

    def difference(self, x_est, x_true) -> np.ndarray:
        """The att/vel/pos error (estimate - truth) between two nominal vectors
        (inverse of ``inject`` to first order): phi from C_true C_est^T, ENU metres."""
        phi = attitude_error_n_rad(x_est[X_C].reshape(3, 3), x_true[X_C].reshape(3, 3))
        dp = earth.position_error_enu_m(x_est[X_LAT], x_est[X_LON], x_est[X_ALT], x_true[X_LAT], x_true[X_LON],
                                        x_true[X_ALT])
        return np.concatenate([phi, x_est[X_VEL] - x_true[X_VEL], dp])

    def feed_back(self, x, x_then, x_anchor, S, S_then, gains):
        """The complementary output predictor's correction (core.fast.nominal.enu_feed_back)."""
        return fast_nominal.enu_feed_back(x, x_then, x_anchor, S, S_then, *gains)

    def small_difference(self, x_est, x_true) -> np.ndarray:
        """``difference`` for small angles (the skew part of C_true C_est^T;
        compiled, core.fast.nominal): the output predictor's feedback."""
        return fast_nominal.enu_difference(x_est, x_true)

    def fast_inject(self, x, dx9) -> np.ndarray:
        """``inject`` in compiled form (core.fast.enu)."""
        return fast_enu.inject(x, dx9)

    def inject(self, x, dx9) -> np.ndarray:
        """Nominal minus the att/vel/pos error estimate (estimate - truth):
        C_true = (I + [phi x]) C_est, position error in local ENU metres."""
        out = x.copy()
        C = rotvec_to_C(dx9[0:3]) @ x[X_C].reshape(3, 3)
        out[X_C] = C.ravel()
        out[X_VEL] = x[X_VEL] - dx9[3:6]
        d_e, d_n, d_u = dx9[6:9]
        lat, alt = x[X_LAT], x[X_ALT]
        r_m, r_n = earth.radii(lat)
        lat1 = lat - d_n / (r_m + alt)
        out[X_LAT] = lat1
        out[X_LON] = earth.wrap_lon_rad(x[X_LON] - d_e / ((r_n + alt) * np.cos(lat1)))
        out[X_ALT] = alt - d_u
        return out
