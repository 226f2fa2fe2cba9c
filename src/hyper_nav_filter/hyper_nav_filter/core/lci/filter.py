"""Error-state Kalman filter with the nominal state in the launch-centred
inertial frame (LCI, seed 001): a drop-in for ``core.eskf.ErrorStateKF``.

What differs from the ENU filter:
  * the nominal state is an ``LciState`` (r_a, v_a inertial, C_b_a, biases),
    mechanized by ``lci.mechanization.propagate`` (one-plus-previous
    coning/sculling/scrolling) with the gravitation of ``cfg.lci_gravity``
    (J2 by default);
  * the covariance is propagated with the 15-state LCI error model
    (``lci.error_model.system_matrices``): the error state att/vel/pos is in
    LCI axes (phi_a, dv_a inertial, dr_a), bg/ba in body axes; the optional
    scale-factor blocks sg/sa (body) make it 21 states;
  * GNSS position/velocity fixes (``GnssPosition`` / ``GnssVelocity``, geodetic
    + ENU covariance) are converted to ECEF and applied with
    ``gnss_position_ecef`` / ``gnss_velocity_ecef``; other measurement kinds
    raise ``UnsupportedMeasurement``.
Gating, the Joseph update and the bookkeeping are ``ErrorStateKF.update``
unchanged (it calls the ``_inject`` overridden here).

Interface toward the engine and outputs (same as ErrorStateKF):
  * ``state`` is a property: the NavState (geodetic, ENU ground velocity,
    C_b_n) converted from the LCI state (cached until the state changes;
    treat it as read-only, assigning a NavState re-initialises the LCI state);
  * ``P`` is the *LCI* error covariance (what the update uses);
    ``P_enu()`` gives it in the ENU error convention of ErrorStateKF;
  * ``snapshot()`` returns an ``LciFilterSnapshot``: its ``state`` is the ENU
    NavState and its ``P`` the ENU covariance (what ``Solution`` and the
    outputs read), ``lci``/``P_lci`` carry the filter state for ``restore``;
  * ``last_Phi``, ``P_prior``, ``epoch_dx`` are in the LCI error frame; the
    RTS smoother (core.smoother.rts_smooth, given this filter) runs in that
    frame with the snapshots' ``P_lci``.
The launch frame: launch point = the initial geodetic position, launch epoch
t0 = initial.t_s, azimuth ``cfg.launch_azimuth_deg``, unless a ``LaunchFrame``
is passed as ``frame``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import earth
from ..attitude import skew
from ..config import ConfigError, FilterConfig
from ..eskf import ErrorStateKF, FilterSnapshot
from ..measurements import GnssPosition, GnssVelocity
from ..nav_state import ImuSample, NavState
from ..state_layout import StateLayout
from . import error_model as lci_err
from . import mechanization as lci_mech
from .frames import OMEGA_IE_RADPS, LaunchFrame
from .gravity import make_gravity

SUPPORTED_BLOCKS = ("att", "vel", "pos", "bg", "ba", "sg", "sa")


class UnsupportedMeasurement(TypeError):
    """The LCI filter has no model for this measurement kind."""


@dataclass
class LciFilterSnapshot(FilterSnapshot):
    """FilterSnapshot whose ``state``/``P`` are the ENU view (for Solution and
    the outputs) plus the LCI state and covariance the filter resumes from."""
    lci: lci_mech.LciState
    P_lci: np.ndarray


class LciErrorStateKF(ErrorStateKF):
    def __init__(self, config: FilterConfig, state: NavState, P0: np.ndarray,
                 frame: LaunchFrame | None = None):
        """``P0`` in the ENU error convention of ErrorStateKF (e.g.
        ``cfg.initial_covariance()``); it is rotated into LCI here."""
        extra = [n for n in config.layout.names if n not in SUPPORTED_BLOCKS]
        if extra:
            raise ConfigError(f"filter config field 'state_blocks': the LCI filter supports only "
                              f"{SUPPORTED_BLOCKS}, got extra blocks {extra}")
        self.frame = frame or LaunchFrame(float(state.lat_rad), float(state.lon_rad), float(state.alt_m),
                                          np.deg2rad(config.launch_azimuth_deg), float(state.t_s))
        self._gravity = make_gravity(config.lci_gravity, self.frame)
        self._nav: NavState | None = None
        self._C_n_a_cache: np.ndarray | None = None
        self._lci: lci_mech.LciState | None = None
        super().__init__(config, state, P0)       # sets self.state (-> LCI) and self.P
        lay = self.layout
        T = self._T_a_n(self._lci)
        self.P = T @ P0 @ T.T
        self.P = 0.5 * (self.P + self.P.T)
        self.P_prior = self.P.copy()
        # continuous noise PSD in the column order of lci_err.system_matrices
        # (w_g, w_a, w_bg, w_ba)
        cols = self._noise["columns"]
        psd = self._noise["psd"]
        self._Qc = np.concatenate([psd[cols["w_g"]], psd[cols["w_a"]],
                                   psd[cols["bg"]] if lay.has("bg") else np.zeros(3),
                                   psd[cols["ba"]] if lay.has("ba") else np.zeros(3)])

    # ---- nominal state views ------------------------------------------------------
    @property
    def lci_state(self) -> lci_mech.LciState:
        return self._lci

    @property
    def state(self) -> NavState:
        """The nominal state as a geodetic/ENU NavState (read-only view)."""
        if self._nav is None:
            s = self._lci
            # lci_to_geodetic, with C_e_a built once (this runs every epoch)
            ang = OMEGA_IE_RADPS * (s.t_s - self.frame.t0_s)
            c, sn = np.cos(ang), np.sin(ang)
            C_e_a = self.frame.C_t_a @ np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
            r_e = C_e_a.T @ (s.r_a_m + self.frame.R0_a_m)
            v_e = C_e_a.T @ s.v_a_mps - np.array([-OMEGA_IE_RADPS * r_e[1], OMEGA_IE_RADPS * r_e[0], 0.0])
            lat, lon, alt = earth.ecef_to_geodetic(r_e)
            C_n_e = earth.C_n_e(lat, lon)
            self._C_n_a_cache = C_e_a @ C_n_e
            self._nav = NavState(float(s.t_s), float(lat), float(lon), float(alt), C_n_e.T @ v_e,
                                 self._C_n_a_cache.T @ s.C_b_a, s.gyro_bias_b_radps.copy(),
                                 s.accel_bias_b_mps2.copy(), {k: v.copy() for k, v in s.extra.items()})
        return self._nav

    @state.setter
    def state(self, nav: NavState) -> None:
        unsupported = sorted(set(nav.extra) - set(SUPPORTED_BLOCKS))
        if unsupported:
            raise ConfigError(f"the LCI filter carries no extra blocks {unsupported}")
        r_a, v_a, C_b_a = self.frame.geodetic_to_lci(nav.lat_rad, nav.lon_rad, nav.alt_m, nav.vel_enu_mps,
                                                     nav.C_b_n, nav.t_s)
        self._lci = lci_mech.LciState(float(nav.t_s), np.asarray(r_a, float), np.asarray(v_a, float),
                                      np.asarray(C_b_a, float), np.asarray(nav.gyro_bias_b_radps, float).copy(),
                                      np.asarray(nav.accel_bias_b_mps2, float).copy(),
                                      {k: np.asarray(v, float).copy() for k, v in nav.extra.items()})
        self._nav = None

    # ---- error-frame conversion ---------------------------------------------------
    def _C_n_a(self, s: lci_mech.LciState) -> np.ndarray:
        if s is self._lci:
            if self._nav is None or self._C_n_a_cache is None:
                self._nav = None
                self.state                      # noqa: B018  (fills the cache)
            return self._C_n_a_cache
        lat, lon, *_ = self.frame.lci_to_geodetic(s.r_a_m, s.v_a_mps, s.C_b_a, s.t_s)
        return self.frame.C_n_a(lat, lon, s.t_s)

    def _T_a_n(self, s: lci_mech.LciState) -> np.ndarray:
        """Error transform ENU -> LCI: phi_a = C phi_n, dr_a = C dr_n,
        dv_a = C dv_n + omega_ie_a x dr_a (v_a is inertial)."""
        lay = self.layout
        C = self._C_n_a(s)
        T = np.eye(lay.dim)
        a, v, p = lay.sl("att"), lay.sl("vel"), lay.sl("pos")
        T[a, a] = C
        T[v, v] = C
        T[p, p] = C
        T[v, p] = skew(self.frame.omega_ie_a_radps) @ C
        return T

    def _T_n_a(self, s: lci_mech.LciState) -> np.ndarray:
        """Inverse of :meth:`_T_a_n` (LCI -> ENU error convention)."""
        lay = self.layout
        Ct = self._C_n_a(s).T
        T = np.eye(lay.dim)
        a, v, p = lay.sl("att"), lay.sl("vel"), lay.sl("pos")
        T[a, a] = Ct
        T[v, v] = Ct
        T[p, p] = Ct
        T[v, p] = -Ct @ skew(self.frame.omega_ie_a_radps)
        return T

    def P_enu(self) -> np.ndarray:
        """The error covariance in the ENU convention of ErrorStateKF."""
        T = self._T_n_a(self._lci)
        P = T @ self.P @ T.T
        return 0.5 * (P + P.T)

    # ---- bookkeeping for re-processing -------------------------------------------
    def snapshot(self) -> LciFilterSnapshot:
        return LciFilterSnapshot(self.state.copy(), self.P_enu(), self.imu_prev, None,
                                 self.n_updates, self.n_rejected, self.last_nis,
                                 {k: list(v) for k, v in self.stats.items()},
                                 self._lci.copy(), self.P.copy())

    def restore(self, snap: LciFilterSnapshot) -> None:
        if not isinstance(snap, LciFilterSnapshot):
            raise TypeError("LciErrorStateKF.restore needs a snapshot taken by an LciErrorStateKF")
        self._lci = snap.lci.copy()
        self._nav = snap.state.copy()
        self._C_n_a_cache = None
        self.P = snap.P_lci.copy()
        self.stats = {k: list(v) for k, v in snap.stats.items()}
        self.imu_prev = snap.imu_prev
        self.vel_prev_enu_mps = None
        self.n_updates, self.n_rejected, self.last_nis = snap.n_updates, snap.n_rejected, snap.last_nis

    # ---- predict ------------------------------------------------------------------
    def predict(self, imu: ImuSample) -> None:
        """LCI mechanization of one IMU interval and LCI covariance propagation."""
        prior = self._lci
        dth, dv = lci_mech.compensate(imu, prior)
        F, G = lci_err.system_matrices(prior, dv / imu.dt_s, dth / imu.dt_s, self.frame, self.layout,
                                       self.cfg.gyro_bias_tau_s, self.cfg.accel_bias_tau_s)
        Phi, Q = lci_err.discretize(F, G, self._Qc, imu.dt_s)
        self._lci = lci_mech.propagate(prior, imu, self.imu_prev, self._gravity)
        self._nav = None
        self.imu_prev = imu
        self._propagate_covariance(Phi, Q)

    # ---- measurements -------------------------------------------------------------
    def model(self, meas, ctx):
        """(residual, H, R) in the LCI error frame for GNSS position/velocity."""
        s = self._lci
        lever = np.asarray(ctx.lever_arm_b_m, float)
        if isinstance(meas, GnssPosition):
            C_n_e = earth.C_n_e(meas.lat_rad, meas.lon_rad)
            r_e = earth.geodetic_to_ecef(meas.lat_rad, meas.lon_rad, meas.alt_m)
            cov_e = C_n_e @ np.asarray(meas.cov_enu_m2, float) @ C_n_e.T
            return lci_err.gnss_position_ecef(s, self.layout, self.frame, meas.t_s, r_e, cov_e, lever,
                                              ctx.dt_to_meas_s)
        if isinstance(meas, GnssVelocity):
            nav = self.state
            C_n_e = earth.C_n_e(nav.lat_rad, nav.lon_rad)
            v_e = C_n_e @ np.asarray(meas.vel_enu_mps, float)
            cov_e = C_n_e @ np.asarray(meas.cov_enu_m2ps2, float) @ C_n_e.T
            # antenna ECEF position (for omega_ie x r) from the nominal state
            r_e = self.frame.lci_position_to_ecef(s.r_a_m + s.C_b_a @ lever, meas.t_s)
            # the engine gives omega_nb_b; the inertial lever-arm velocity needs omega_ib_b
            w_in = earth.omega_ie_n(nav.lat_rad) + earth.omega_en_n(nav.lat_rad, nav.alt_m, nav.vel_enu_mps)
            omega_ib_b = np.asarray(ctx.omega_nb_b_radps, float) + nav.C_b_n.T @ w_in
            return lci_err.gnss_velocity_ecef(s, self.layout, self.frame, meas.t_s, r_e, v_e, cov_e,
                                              omega_ib_b, lever)
        raise UnsupportedMeasurement(
            f"LciErrorStateKF has no model for measurement kind {getattr(meas, 'kind', type(meas).__name__)!r} "
            f"({type(meas).__name__}); supported: gnss_pos (GnssPosition), gnss_vel (GnssVelocity). "
            f"Use mechanization_frame='ENU' for the other aiding sources.")

    def _inject(self, dx: np.ndarray) -> None:
        self._lci = lci_err.inject(self._lci, dx, self.layout)
        self._nav = None
