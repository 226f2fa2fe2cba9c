"""ICCP: iterative closest contour point (seed 003 section 2.3, Fig. 2;
parameters Table 2).

Every L samples, with the INS positions X_n and the measured values m_n:

1. on the map, the contour F = m_n is the set where sample n could have been;
2. a_n = the point of that contour closest to the current x_n;
3. T = the rigid transform (rotation + translation) minimising
   J = sum_n d^2(a_n, T x_n); X <- T X;
4. repeat from 2 until J < epsilon or the maximum number of iterations;
   the transformed newest position is the fix.

Choices the paper leaves open (ours): the closest contour point is found by
Newton steps along the gradient, a <- a - g (F(a) - m) / |g|^2 (three steps;
for a contour whose radius of curvature is thousands of km, as the WMM's at
25 km, this is the closest point to within millimetres, and it replaces the
contour tracing that makes the paper's ICCP slow). The contour point
must lie inside the matching area (``area_cells`` refined cells, centred on
the INS track) and on the map, or the sequence gives no fix; an area that
reaches over the map's edge is searched where it is on the map (the seed 003
return leg runs 2-15 km from the 109 E edge, inside the 300-cell area's
half-width of 15 km).
Table 2's "critical distance" d_c is read as the stopping threshold
epsilon = d_c^2 on J (in m^2). T is fitted from the original X each
iteration (Procrustes, ``matching.rigid_fit_2d``).

Fix covariance: ``isotropic`` (sigma given) or ``geometry`` (along the
gradient sigma / (|g| sqrt(L)), across ``across_sigma_m``: the contours of
a near-planar field are parallel lines, which pin the sequence along the
gradient and leave it free across it, apart from the rotation).
"""
from __future__ import annotations

import numpy as np

from hyper_nav_aiding.geomag.core.matching import (
    LocalFrame, MatchResult, SequenceMatcher, along_across_sigma, rigid_fit_2d, sequence_cov,
)

NEWTON_STEPS = 3


class Iccp(SequenceMatcher):
    name = "ICCP"

    def _closest_contour_points(self, frame: LocalFrame, P: np.ndarray, m: np.ndarray, half_m: np.ndarray,
                                centre: np.ndarray):
        """Closest points of the contours F = m to the points P (EN metres);
        None where a contour leaves the matching area."""
        A = P.copy()
        alt = np.full(len(m), self.map.spec.alt_m)
        for _ in range(NEWTON_STEPS):
            lat, lon = frame.to_geodetic(A)
            if not np.all(self.map.contains(lat, lon)):
                return A, np.zeros(len(m), bool)
            f, g = self.map.total_and_gradient(lat, lon, alt)
            gh = g[:, :2]
            A = A - gh * ((f - m) / np.sum(gh**2, axis=1))[:, None]
        lat, lon = frame.to_geodetic(A)
        inside = np.all(np.abs(A - centre) <= half_m, axis=1) & self.map.contains(lat, lon)
        return A, inside

    def _match(self, seq, t_s: float) -> MatchResult:
        last = seq[-1][0]
        frame = LocalFrame(last.lat_rad, last.lon_rad, self.map.spec.alt_m)
        X = frame.to_en(np.array([s[0].lat_rad for s in seq]), np.array([s[0].lon_rad for s in seq]))
        m = np.array([s[1] for s in seq])
        step = np.deg2rad(self.map.spec.refined_step_deg)
        half_cells = (self.p.area_cells - 1) / 2.0
        half_m = np.array([half_cells * step * frame.m_per_rad_e, half_cells * step * frame.m_per_rad_n])
        centre = X.mean(axis=0)
        Xt = X
        J = np.inf
        it = 0
        for it in range(1, self.p.max_iterations + 1):
            A, inside = self._closest_contour_points(frame, Xt, m, half_m, centre)
            if not np.all(inside):
                return MatchResult(t_s, self.name, False, "contour point outside the matching area or the map",
                                   code="contour_off_area", iterations=it, sequence_length=len(m))
            R, t = rigid_fit_2d(X, A)
            Xt = X @ R.T + t
            J = float(np.sum((A - Xt) ** 2))
            if J < self.p.critical_distance_m**2:
                break
        fix_lat, fix_lon = frame.to_geodetic(Xt[-1])
        lat, lon = frame.to_geodetic(Xt)
        _, g = self.map.total_and_gradient(lat, lon, np.full(len(m), self.map.spec.alt_m))
        g_h = g[:, :2]
        cov = np.eye(2) * self.iso_sigma_m**2 if self.fix_covariance == "isotropic" else \
            sequence_cov(g_h, self.sigma_nT, self.across_sigma_m)
        along, across = along_across_sigma(cov, g_h[-1])
        return MatchResult(t_s, self.name, True, "", float(fix_lat), float(fix_lon), cov, metric=J,
                           iterations=it, sequence_length=len(m), along_gradient_sigma_m=along,
                           across_gradient_sigma_m=across, gradient_nt_per_km=float(np.linalg.norm(g_h[-1]) * 1e3))
