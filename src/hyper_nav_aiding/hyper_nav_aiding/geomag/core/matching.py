"""Types shared by the geomagnetic matchers and small geometry helpers.

A matcher gets, once per magnetometer epoch, the measured total intensity
and the navigation solution at that epoch, and returns a ``MatchResult``
(a horizontal fix with its EN covariance and quality figures) or None when
it has nothing to say this epoch (e.g. MAGCOM still filling its sequence).
Errors of the map (off-map positions) raise ``OffMapError``; the aiding
engine (``core.geomag_aiding``) turns them into counted invalid results.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hyper_nav_gnss import earth


@dataclass(frozen=True)
class MagSample:
    """Measured total intensity |B| [nT] at epoch t_s (sim time)."""
    t_s: float
    total_nT: float


@dataclass(frozen=True)
class NavPoint:
    """The navigation solution at a magnetometer epoch: geodetic position,
    ENU velocity, the horizontal (E, N) position covariance [m^2], the
    altitude variance [m^2] (NaN when unknown) and the ENU acceleration
    w.r.t. Earth [m/s^2] (for ``predict_nav``)."""
    t_s: float
    lat_rad: float
    lon_rad: float
    alt_m: float
    vel_enu_mps: np.ndarray
    cov_en_m2: np.ndarray
    alt_var_m2: float = float("nan")
    accel_enu_mps2: np.ndarray = field(default_factory=lambda: np.zeros(3))


@dataclass
class MatchResult:
    """One fix (``valid``) or the reason there is none, with the fields of
    hyper_nav_msgs/MatchQuality."""
    t_s: float
    algorithm: str
    valid: bool
    reason: str = ""            # human-readable, for the log and MatchQuality.reason
    lat_rad: float = float("nan")
    lon_rad: float = float("nan")
    cov_en_m2: np.ndarray = field(default_factory=lambda: np.full((2, 2), np.nan))
    # a 3-D fix (EKF with ``vertical``): altitude and the full ENU covariance; None = horizontal
    alt_m: float = float("nan")
    cov_enu_m2: np.ndarray | None = None
    metric: float = float("nan")
    iterations: int = 0
    sequence_length: int = 0
    along_gradient_sigma_m: float = float("nan")
    across_gradient_sigma_m: float = float("nan")
    gradient_nt_per_km: float = float("nan")
    compute_time_s: float = 0.0
    # F at the measurement epoch - F of the map at the solution (nT; core.map_epoch eq. 2): the secular
    # change the map does not hold; NaN when the engine has no epoch check
    map_epoch_bias_nT: float = float("nan")
    code: str = ""              # short category for the counters ("off_map", "contour_off_area", ...)


class LocalFrame:
    """Local east/north metres around a reference point (the tangent plane;
    over a matching area of tens of km the difference from geodesic
    distances is below 1e-4 relative)."""

    def __init__(self, lat0_rad: float, lon0_rad: float, alt_m: float):
        self.lat0, self.lon0 = float(lat0_rad), float(lon0_rad)
        r_m, r_n = earth.radii(self.lat0)
        self.m_per_rad_n = r_m + alt_m
        self.m_per_rad_e = (r_n + alt_m) * np.cos(self.lat0)

    def to_en(self, lat_rad, lon_rad) -> np.ndarray:
        return np.stack([(np.asarray(lon_rad) - self.lon0) * self.m_per_rad_e,
                         (np.asarray(lat_rad) - self.lat0) * self.m_per_rad_n], axis=-1)

    def to_geodetic(self, en) -> tuple[np.ndarray, np.ndarray]:
        en = np.asarray(en, float)
        return self.lat0 + en[..., 1] / self.m_per_rad_n, self.lon0 + en[..., 0] / self.m_per_rad_e


def interpolate_nav(a: NavPoint, b: NavPoint, t_s: float) -> NavPoint:
    """Linear interpolation of two solutions bracketing t_s (covariance of
    the nearer one)."""
    if b.t_s == a.t_s:
        return a
    w = (t_s - a.t_s) / (b.t_s - a.t_s)
    near = a if w < 0.5 else b
    return NavPoint(t_s, a.lat_rad + w * (b.lat_rad - a.lat_rad), a.lon_rad + w * (b.lon_rad - a.lon_rad),
                    a.alt_m + w * (b.alt_m - a.alt_m), a.vel_enu_mps + w * (b.vel_enu_mps - a.vel_enu_mps),
                    near.cov_en_m2, near.alt_var_m2, a.accel_enu_mps2 + w * (b.accel_enu_mps2 - a.accel_enu_mps2))


def predict_nav(nav: NavPoint, t_s: float) -> NavPoint:
    """The solution carried forward to t_s at constant acceleration
    (r + v dt + a dt^2 / 2). The fusion node releases a solution
    ``output_delay_s`` (1 s) behind; carrying the newest one forward lets a
    fix for t reach the filter before it releases t, instead of a late fix
    re-processing a second of IMU epochs. A linearization point off by the
    prediction error (jerk dt^3 / 6: < 1 m over 1 s at the 4 g turn's onset)
    changes nothing along the gradient: the matchers estimate the error of
    the reference they are given, and over a near-planar field a fix's
    along-gradient coordinate does not depend on the linearization point."""
    dt = t_s - nav.t_s
    d = nav.vel_enu_mps * dt + 0.5 * nav.accel_enu_mps2 * dt * dt
    lat, lon = LocalFrame(nav.lat_rad, nav.lon_rad, nav.alt_m).to_geodetic(d[:2])
    return NavPoint(t_s, float(lat), float(lon), float(nav.alt_m + d[2]), nav.vel_enu_mps + nav.accel_enu_mps2 * dt,
                    nav.cov_en_m2, nav.alt_var_m2, nav.accel_enu_mps2)


def gradient_frame_cov(grad_en: np.ndarray, sigma_along_m: float, sigma_across_m: float) -> np.ndarray:
    """EN covariance with the given sigmas along and across the horizontal gradient."""
    u = np.asarray(grad_en, float) / np.linalg.norm(grad_en)
    v = np.array([-u[1], u[0]])
    return sigma_along_m**2 * np.outer(u, u) + sigma_across_m**2 * np.outer(v, v)


def sequence_cov(g_h: np.ndarray, sigma_nT: float, across_sigma_m: float) -> np.ndarray:
    """Fix covariance of a sequence of L samples matched along the gradient
    only: sigma / (|g| sqrt(L)) along the mean gradient, ``across_sigma_m``
    across (nothing in a near-planar field constrains that direction)."""
    g = np.asarray(g_h, float).mean(axis=0)
    along = sigma_nT / (np.linalg.norm(g) * np.sqrt(len(g_h)))
    return gradient_frame_cov(g, along, across_sigma_m)


def along_across_sigma(cov_en: np.ndarray, grad_en: np.ndarray) -> tuple[float, float]:
    u = np.asarray(grad_en, float) / np.linalg.norm(grad_en)
    v = np.array([-u[1], u[0]])
    return float(np.sqrt(u @ cov_en @ u)), float(np.sqrt(v @ cov_en @ v))


def rigid_fit_2d(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R (2x2) and translation t minimising sum |dst - (R src + t)|^2
    (Procrustes / Umeyama without scale, via the SVD)."""
    cs, cd = src.mean(axis=0), dst.mean(axis=0)
    Hm = (src - cs).T @ (dst - cd)
    U, _, Vt = np.linalg.svd(Hm)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, d]) @ U.T
    return R, cd - R @ cs


class SequenceMatcher:
    """What MAGCOM and ICCP share: a sequence of ``params.sequence_length``
    magnetometer samples, each reduced to the map altitude with the map's
    dF/dh layer and paired with its INS position, matched as a whole
    (``_match``, the subclass's algorithm) when complete, then started afresh."""
    name = "sequence"

    def __init__(self, gmap, params, field_sigma_nT: float, fix_covariance: str,
                 isotropic_sigma_m: float, across_sigma_m: float):
        self.map = gmap
        self.p = params
        self.sigma_nT = field_sigma_nT
        self.fix_covariance = fix_covariance
        self.iso_sigma_m = isotropic_sigma_m
        self.across_sigma_m = across_sigma_m
        self._seq: list[tuple[NavPoint, float]] = []

    def reset(self) -> None:
        self._seq = []

    def step(self, sample: MagSample, nav: NavPoint) -> MatchResult | None:
        m_map_alt = sample.total_nT - float(self.map.layer("dF_dh", np.rad2deg(nav.lat_rad), np.rad2deg(nav.lon_rad))) \
            * (nav.alt_m - self.map.spec.alt_m)
        self._seq.append((nav, m_map_alt))
        if len(self._seq) < self.p.sequence_length:
            return None
        seq, self._seq = self._seq, []
        return self._match(seq, sample.t_s)

    def _match(self, seq, t_s: float) -> MatchResult:
        raise NotImplementedError
