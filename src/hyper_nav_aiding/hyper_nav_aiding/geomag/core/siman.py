"""SIMAN: Sandia inertial magnetic aided navigation (seed 003 section 2.4,
eqs. 7-12, Fig. 3; Table 2).

A two-state Kalman filter on the horizontal position error of the
navigation solution, dX = [dE, dN] (m; the paper's [dL, dlambda] in radians
scaled by the radii: dN = (R_M + h) dL, dE = (R_N + h) cos L dlambda,
which keeps the covariance well conditioned):

    dX_k+1 = Phi dX_k + W_k,  Phi = I                     (eq. 7)
    Z = m_map(L^, lambda^) - m_mea = H dX + V              (eqs. 9-12)

with H = [h_E, h_N] the slopes of the plane fitted by least squares to the
map at the nine refined grid nodes around the indicated position
("nine-point plane fitting", eq. 12). The corrected position (indicated
minus dX) is the fix, with covariance P. Step (4), "SINS is compensated and
corrected according to the output of the filter": in the closed loop the
fusion filter applies the fix with its gain K_f = P_nav (P_nav + P)^-1, so
the error left in the next indicated position is (I - K_f) dX, which is
where the state goes after each fix (P_nav from nav/state).

Choices the paper leaves open (ours, parameters): the process noise W_k
(random walk ``q_m2_per_s``), the measurement variance (the assumed field
error ``field_sigma_nT`` squared) and the units of Table 2's P0 = I (read as
km^2: 1 km 1-sigma, which covers the INS error at 420 s). The measured value
is compared with the map at the indicated altitude (dF/dh).
"""
from __future__ import annotations

import numpy as np

from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap
from hyper_nav_aiding.geomag.core.matching import LocalFrame, MagSample, MatchResult, NavPoint, along_across_sigma


def nine_point_plane_fit(gmap: GeomagMap, lat_rad: float, lon_rad: float, alt_m: float, spacing_cells: int = 1):
    """Slopes (dF/dE, dF/dN) [nT/m] of the least-squares plane through the
    map at the 3 x 3 refined grid nodes nearest the point (node spacing
    ``spacing_cells`` refined cells), at altitude alt_m."""
    s = gmap.spec
    st = s.refined_step_deg * spacing_cells
    la0 = s.lat_min_deg + round((np.rad2deg(lat_rad) - s.lat_min_deg) / st) * st
    lo0 = s.lon_min_deg + round((np.rad2deg(lon_rad) - s.lon_min_deg) / st) * st
    k = np.array([-1.0, 0.0, 1.0]) * st
    la, lo = np.meshgrid(la0 + k, lo0 + k, indexing="ij")
    f = gmap.total_nT(np.deg2rad(la.ravel()), np.deg2rad(lo.ravel()), np.full(9, alt_m))
    frame = LocalFrame(np.deg2rad(la0), np.deg2rad(lo0), alt_m)
    en = frame.to_en(np.deg2rad(la.ravel()), np.deg2rad(lo.ravel()))
    A = np.column_stack([np.ones(9), en])
    coef, *_ = np.linalg.lstsq(A, f, rcond=None)
    return coef[1:]


class Siman:
    name = "SIMAN"

    def __init__(self, gmap: GeomagMap, params, field_sigma_nT: float):
        self.map = gmap
        self.p = params
        self.R = field_sigma_nT**2
        self.reset()

    def reset(self) -> None:
        self.dx = np.array([self.p.x0_m[1], self.p.x0_m[0]], float)     # Table 2 order [N, E] -> [E, N]
        self.P = np.diag([self.p.p0_m2[1], self.p.p0_m2[0]]).astype(float)
        self.t_last = None

    def step(self, sample: MagSample, nav: NavPoint) -> MatchResult:
        if self.t_last is not None:
            self.P = self.P + np.eye(2) * self.p.q_m2_per_s * (sample.t_s - self.t_last)
        self.t_last = sample.t_s
        H = nine_point_plane_fit(self.map, nav.lat_rad, nav.lon_rad, nav.alt_m, self.p.plane_fit_cells)
        z = float(self.map.total_nT(nav.lat_rad, nav.lon_rad, nav.alt_m)) - sample.total_nT
        S = H @ self.P @ H + self.R
        K = self.P @ H / S
        innov = z - H @ self.dx
        self.dx = self.dx + K * innov
        IKH = np.eye(2) - np.outer(K, H)
        self.P = IKH @ self.P @ IKH.T + np.outer(K, K) * self.R
        frame = LocalFrame(nav.lat_rad, nav.lon_rad, nav.alt_m)
        lat, lon = frame.to_geodetic(-self.dx)
        cov = self.P.copy()
        # closed loop (step 4): the fusion filter removes K_f dX from the solution
        P_nav = np.asarray(nav.cov_en_m2, float)
        if np.all(np.isfinite(P_nav)):
            K_f = P_nav @ np.linalg.inv(P_nav + self.P)
            self.dx = (np.eye(2) - K_f) @ self.dx
        along, across = along_across_sigma(cov, H)
        return MatchResult(sample.t_s, self.name, True, "", float(lat), float(lon), cov,
                           metric=float(innov**2 / S), iterations=1, sequence_length=1,
                           along_gradient_sigma_m=along, across_gradient_sigma_m=across,
                           gradient_nt_per_km=float(np.linalg.norm(H) * 1e3))
