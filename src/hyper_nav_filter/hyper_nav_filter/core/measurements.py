"""Measurement models: each returns (residual, H, R) for the current nominal
state, residual = predicted - measured (STYLE pattern 4). The filter loop
does gating, the Joseph update and bookkeeping for all of them.

Models are written once, frame-neutral: on the geodetic/ENU view of the
state (``NavState``), with H in the ENU error convention (att phi ENU rad,
vel ENU m/s, pos ENU m, other blocks as ``core.state_layout``). Every
filter maps H into its own error state (``ErrorStateKF.model``), so the ENU
and the LCI filter accept every model. ``coupling`` says what kind of aiding
a model is ("loose" GNSS, "tight" GNSS, other "aiding"), for the solution's
mode.

GNSS loosely coupled models with antenna lever arm l_b (body FLU, m):
    r_ant = r + C_b_n l_b                       (position, ENU metres)
    v_ant = v + C_b_n (omega_nb_b x l_b)         (velocity, ENU m/s)
"""
from __future__ import annotations

from dataclasses import dataclass

import math

import numpy as np

from hyper_nav_gnss import earth
from .attitude import cross3, skew
from .fast import gnss as fast_gnss
from .nav_state import NavState
from .state_layout import StateLayout


class Measurement:
    """What every measurement declares, read by the engine and the filter
    as attributes (never probed for): ``kind`` (its counters' name, a field
    of each measurement), ``coupling`` ("loose", "tight" or other "aiding":
    the solution's mode), ``state_resets`` (block elements taken anew before
    the update, ``ErrorStateKF.apply_resets``), ``fast_model`` (``model`` in
    compiled form on the geodetic/ENU view, or None) and ``model``. A
    measurement type (here, in an aiding package or a user's plugin)
    subclasses it and overrides what it has."""
    coupling = "aiding"
    state_resets = ()
    fast_model = None

    def model(self, state: NavState, layout: StateLayout, ctx: "ModelContext"):
        """(residual, H, R) at ``state``, residual = predicted - measured, H in the ENU error convention."""
        raise NotImplementedError(f"{type(self).__name__}.model")


@dataclass(frozen=True)
class GnssPosition(Measurement):
    """GNSS antenna position fix at epoch t_s; covariance in ENU (m^2)."""
    t_s: float
    lat_rad: float
    lon_rad: float
    alt_m: float
    cov_enu_m2: np.ndarray
    kind: str = "gnss_pos"
    coupling = "loose"

    def model(self, state: NavState, layout: StateLayout, ctx: "ModelContext"):
        l_n = state.C_b_n @ ctx.lever_arm_b_m
        pred_enu = earth.position_error_enu_m(state.lat_rad, state.lon_rad, state.alt_m,
                                              self.lat_rad, self.lon_rad, self.alt_m)
        residual = pred_enu + l_n + state.vel_enu_mps * ctx.dt_to_meas_s
        H = np.zeros((3, layout.dim))
        H[:, layout.sl("pos")] = np.eye(3)
        H[:, layout.sl("att")] = skew(l_n)
        return residual, H, self.cov_enu_m2

    def fast_model(self, geo, layout: StateLayout, ctx: "ModelContext"):
        """``model`` in compiled form (``core.fast.gnss.position``) on the
        state's (lat, lon, alt, vel_enu, C_b_n)."""
        lat, lon, alt, v, C = geo
        residual, H = fast_gnss.position(lat, lon, alt, v, C, float(self.lat_rad), float(self.lon_rad),
                                         float(self.alt_m), ctx.lever_arm_b_m, ctx.dt_to_meas_s, layout.dim,
                                         layout.start("pos"), layout.start("att"))
        return residual, H, self.cov_enu_m2


@dataclass(frozen=True)
class GnssVelocity(Measurement):
    """GNSS antenna velocity w.r.t. Earth at epoch t_s; ENU, covariance (m/s)^2."""
    t_s: float
    vel_enu_mps: np.ndarray
    cov_enu_m2ps2: np.ndarray
    kind: str = "gnss_vel"
    coupling = "loose"

    def model(self, state: NavState, layout: StateLayout, ctx: "ModelContext"):
        lever_vel_b = cross3(ctx.omega_nb_b_radps, ctx.lever_arm_b_m)
        lever_vel_n = state.C_b_n @ lever_vel_b
        residual = state.vel_enu_mps + lever_vel_n - self.vel_enu_mps
        H = np.zeros((3, layout.dim))
        H[:, layout.sl("vel")] = np.eye(3)
        H[:, layout.sl("att")] = skew(lever_vel_n)
        if layout.has("bg"):
            H[:, layout.sl("bg")] = state.C_b_n @ skew(ctx.lever_arm_b_m)
        return residual, H, self.cov_enu_m2ps2

    def fast_model(self, geo, layout: StateLayout, ctx: "ModelContext"):
        """``model`` in compiled form (``core.fast.gnss.velocity``)."""
        residual, H = fast_gnss.velocity(geo[3], geo[4], np.asarray(self.vel_enu_mps, dtype=np.float64),
                                         ctx.omega_nb_b_radps, ctx.lever_arm_b_m, layout.dim, layout.start("vel"),
                                         layout.start("att"), layout.start("bg"))
        return residual, H, self.cov_enu_m2ps2


@dataclass(frozen=True)
class BaroHeight(Measurement):
    """Barometric altitude (above the ellipsoid, after the pressure-to-height
    inversion) at epoch t_s, variance in m^2 (seed 003's altitude channel)."""
    t_s: float
    alt_m: float
    var_m2: float
    kind: str = "baro"
    coupling = "aiding"

    def model(self, state: NavState, layout: StateLayout, ctx: "ModelContext"):
        H = np.zeros((1, layout.dim))
        H[0, layout.sl("pos").start + 2] = 1.0
        residual = np.array([state.alt_m + state.vel_enu_mps[2] * ctx.dt_to_meas_s - self.alt_m])
        return residual, H, np.array([[self.var_m2]])


@dataclass(frozen=True)
class HorizontalFix(Measurement):
    """Horizontal position fix (e.g. geomagnetic matching, seed 003 eqs.
    20-26): latitude/longitude with a 2x2 covariance in (E, N) m^2."""
    t_s: float
    lat_rad: float
    lon_rad: float
    cov_en_m2: np.ndarray
    kind: str = "horizontal_fix"
    coupling = "aiding"

    def model(self, state: NavState, layout: StateLayout, ctx: "ModelContext"):
        d = earth.position_error_enu_m(state.lat_rad, state.lon_rad, state.alt_m,
                                       self.lat_rad, self.lon_rad, state.alt_m)
        residual = d[:2] + state.vel_enu_mps[:2] * ctx.dt_to_meas_s
        H = np.zeros((2, layout.dim))
        p = layout.sl("pos")
        H[0, p.start] = 1.0
        H[1, p.start + 1] = 1.0
        return residual, H, self.cov_en_m2


@dataclass(frozen=True)
class PositionFix(Measurement):
    """3-D position fix of an aiding source (no antenna lever arm): latitude,
    longitude, altitude with a full ENU covariance (m^2), which may be
    degenerate, e.g. the geomagnetic pseudo-fix that informs one direction
    only (hyper_nav_aiding ``ekf_intensity``: the scalar update along the 3-D
    field gradient, seed 003 eq. 11)."""
    t_s: float
    lat_rad: float
    lon_rad: float
    alt_m: float
    cov_enu_m2: np.ndarray
    kind: str = "position_fix"
    coupling = "aiding"

    def model(self, state: NavState, layout: StateLayout, ctx: "ModelContext"):
        d = earth.position_error_enu_m(state.lat_rad, state.lon_rad, state.alt_m,
                                       self.lat_rad, self.lon_rad, self.alt_m)
        H = np.zeros((3, layout.dim))
        H[:, layout.sl("pos")] = np.eye(3)
        return d + state.vel_enu_mps * ctx.dt_to_meas_s, H, self.cov_enu_m2


class ModelContext:
    """Quantities a model needs besides the state: the antenna lever arm
    (body FLU, m), the body rate relative to ENU (rad/s, body axes; computed
    once per epoch, only when a model asks for it) and the measurement epoch
    minus the state epoch (s). ``cache``: a dict shared by the contexts of
    one pass over one epoch (``shifted`` keeps it; a re-processed epoch gets
    a new one), where a model may keep what it computes once per epoch
    (the per-satellite pseudoranges' corrections: ``RawPseudoranges``)."""
    __slots__ = ("lever_arm_b_m", "_omega", "dt_to_meas_s", "cache")

    def __init__(self, lever_arm_b_m, omega_nb_b_radps=None, dt_to_meas_s: float = 0.0, cache: dict | None = None):
        self.lever_arm_b_m = np.asarray(lever_arm_b_m, float)
        self.cache = {} if cache is None else cache
        # a shared one-element box: a value, or a callable computing it
        self._omega = omega_nb_b_radps if isinstance(omega_nb_b_radps, list) else \
            [np.zeros(3) if omega_nb_b_radps is None else np.asarray(omega_nb_b_radps, float)]
        self.dt_to_meas_s = float(dt_to_meas_s)

    @property
    def omega_nb_b_radps(self) -> np.ndarray:
        if callable(self._omega[0]):
            self._omega[0] = self._omega[0]()
        return self._omega[0]

    def shifted(self, dt_to_meas_s: float) -> "ModelContext":
        """The same context for a measurement dt_to_meas_s after the state epoch."""
        return ModelContext(self.lever_arm_b_m, self._omega, dt_to_meas_s, self.cache)

    @classmethod
    def at(cls, kf, imu, lever_arm_b_m) -> "ModelContext":
        """Context at a filter's current epoch (after its predict), whose last
        IMU interval is ``imu``:
        omega_nb_b = corrected omega_ib_b - C_b_n^T (omega_ie_n + omega_en_n)."""
        t, x, vals = kf.t_s, kf.x_nav, kf.values

        def omega():
            lat, _, alt, v, C = kf.frame.view(x, t)
            if kf.fast:
                return fast_gnss.omega_nb_b(lat, alt, v, C, np.asarray(imu.dtheta_b_rad, dtype=np.float64),
                                            np.asarray(imu.dvel_b_mps, dtype=np.float64), float(imu.dt_s), vals,
                                            *kf.sys.roles_args)
            w_ib = kf.corrected(imu.dtheta_b_rad, imu.dvel_b_mps, imu.dt_s, vals)[0] / imu.dt_s
            w_in = earth.omega_ie_n(lat) + earth.omega_en_n(lat, alt, v)
            return w_ib - C.T @ w_in
        return cls(lever_arm_b_m, [omega], 0.0)


def is_finite(meas) -> bool:
    """True when every numeric field of a measurement is finite (NaN and inf
    propagate through a sum, so one reduction per array suffices)."""
    for v in vars(meas).values():
        t = type(v)
        if t is float or t is int:
            if not math.isfinite(v):
                return False
        elif t is np.ndarray and v.dtype.kind == "f":
            if not math.isfinite(float(v.sum())):
                return False
    return True
