"""MAGCOM: geomagnetic contour matching by exhaustive search (seed 003
section 2.2, eqs. 2-6, Fig. 1; parameters Table 2).

Every L magnetometer samples the INS positions of the sequence X (eq. 2's
M_mea measured there) are translated over a P x Q area of refined grid cells
centred on the INS track and rotated about their centre by beta in
[-theta, theta] with a step (eqs. 4-5); the candidate with the smallest mean
square difference (eq. 6)

    MSD(i, j, beta) = 1/L sum_l [m_map(x'_l) - m_mea_l]^2

is the match, and the matched position of the newest sample is the fix.
Sequences do not overlap: the fix of one sequence is applied before the next
one starts, so each sequence's relative track is the aided INS of that span.

Choices the paper leaves open (ours): the rotation is a rotation in local
east/north metres about the sequence's centroid (eq. 5's grid indices are
not isotropic: a longitude cell is cos(lat) shorter); map values come from
the map's spline (its values at the refined nodes are the refined map);
measurements are carried to the map altitude with dF/dh at the INS altitude.

Fix covariance: ``isotropic`` (the paper's 2-D fix, sigma given) or
``geometry``: the Laplace approximation of the MSD surface, sigma^2 (sum_l
g_l g_l^T)^-1 at the match (g_l the map gradient), plus the cell
quantization, with the across-gradient sigma capped at ``across_sigma_m``.
Over a map that is a plane to 0.1 % the MSD is flat across the gradient:
the minimum there is decided by noise, which is why MAGCOM's fixes wander
across the gradient.
"""
from __future__ import annotations

import numpy as np

from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap, OffMapError
from hyper_nav_aiding.geomag.core.matching import LocalFrame, MatchResult, SequenceMatcher, along_across_sigma


class Magcom(SequenceMatcher):
    name = "MAGCOM"

    def __init__(self, gmap: GeomagMap, params, field_sigma_nT: float, fix_covariance: str,
                 isotropic_sigma_m: float, across_sigma_m: float):
        super().__init__(gmap, params, field_sigma_nT, fix_covariance, isotropic_sigma_m, across_sigma_m)
        half = (params.area_cells - 1) // 2
        k = np.arange(-half, half + 1)
        self._di, self._dj = [a.ravel() for a in np.meshgrid(k, k, indexing="ij")]   # lat, lon cell offsets
        n_beta = int(np.floor(params.rotation_max_deg / params.rotation_step_deg + 1e-9))
        self._beta = np.deg2rad(params.rotation_step_deg * np.arange(-n_beta, n_beta + 1))

    def _match(self, seq, t_s: float) -> MatchResult:
        last = seq[-1][0]
        frame = LocalFrame(last.lat_rad, last.lon_rad, self.map.spec.alt_m)
        X = frame.to_en(np.array([s[0].lat_rad for s in seq]), np.array([s[0].lon_rad for s in seq]))
        m = np.array([s[1] for s in seq])
        c = X.mean(axis=0)
        cb, sb = np.cos(self._beta), np.sin(self._beta)
        R = np.stack([np.stack([cb, -sb], -1), np.stack([sb, cb], -1)], -2)          # (B, 2, 2)
        Xr = np.einsum("bij,lj->bli", R, X - c) + c                                 # (B, L, 2)
        lat_r, lon_r = frame.to_geodetic(Xr)                                         # rad
        step = np.deg2rad(self.map.spec.refined_step_deg)
        lat = np.rad2deg(lat_r[:, None, :] + self._di[None, :, None] * step)        # (B, PQ, L)
        lon = np.rad2deg(lon_r[:, None, :] + self._dj[None, :, None] * step)
        s = self.map.spec
        if lat.min() < s.lat_min_deg or lat.max() > s.lat_max_deg or lon.min() < s.lon_min_deg \
                or lon.max() > s.lon_max_deg:
            raise OffMapError(f"MAGCOM matching area around {np.rad2deg(last.lat_rad):.4f} N "
                              f"{np.rad2deg(last.lon_rad):.4f} E leaves the map")
        vals = self.map.total_on_map_surface_nT(lat.ravel(), lon.ravel()).reshape(lat.shape)
        msd = np.mean((vals - m) ** 2, axis=-1)                                      # (B, PQ)
        b, q = np.unravel_index(int(np.argmin(msd)), msd.shape)
        fix_lat = np.deg2rad(lat[b, q, -1])
        fix_lon = np.deg2rad(lon[b, q, -1])
        # gradient at the matched points (map altitude) for the covariance and quality
        _, g = self.map.total_and_gradient(np.deg2rad(lat[b, q]), np.deg2rad(lon[b, q]),
                                           np.full(len(m), s.alt_m))
        g_h = g[:, :2]
        g_last = g_h[-1]
        if self.fix_covariance == "isotropic":
            cov = np.eye(2) * self.iso_sigma_m**2
        else:
            cov = _laplace_cov(g_h, self.sigma_nT, self.across_sigma_m, frame, step)
        along, across = along_across_sigma(cov, g_last)
        return MatchResult(t_s, self.name, True, "", float(fix_lat), float(fix_lon), cov,
                           metric=float(msd[b, q]), iterations=int(msd.size), sequence_length=len(m),
                           along_gradient_sigma_m=along, across_gradient_sigma_m=across,
                           gradient_nt_per_km=float(np.linalg.norm(g_last) * 1e3))


def _laplace_cov(g_h: np.ndarray, sigma_nT: float, across_cap_m: float, frame: LocalFrame,
                 step_rad: float) -> np.ndarray:
    """sigma^2 (sum g g^T)^-1 with the weak direction capped, plus the
    translation quantization (uniform over one cell: cell^2 / 12)."""
    info = g_h.T @ g_h / sigma_nT**2
    w, V = np.linalg.eigh(info)
    var = 1.0 / np.maximum(w, 1.0 / across_cap_m**2)
    cov = (V * var) @ V.T
    cell_e, cell_n = step_rad * frame.m_per_rad_e, step_rad * frame.m_per_rad_n
    return cov + np.diag([cell_e**2, cell_n**2]) / 12.0

