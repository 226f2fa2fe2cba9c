"""The PCRB of ``core.pcrb`` assembled for a flight over a geomagnetic map.

``FlightBound`` holds what does not depend on the map-error level (the
error-state transitions along the truth, the map gradient at the true
positions, the barometer sigma) and evaluates the bound for one level and
reading: total intensity (the paper's matching), or the three field
components with the attitude error they bring in (``components='vector'``,
the further step of the issue: 1 nT of a 57,000 nT field is 3.6 arcsec of
attitude).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core.attitude import skew

from hyper_nav_aiding.geomag.core import pcrb
from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap


@dataclass
class FlightBound:
    t_s: np.ndarray                 # 1 Hz epochs from 0
    transitions: pcrb.ErrorTransitions
    P0: np.ndarray
    layout: object
    grad: np.ndarray                # (N, 3) dF/d(E, N, U) at the truth, nT/m
    B_enu: np.ndarray               # (N, 3) field at the truth, nT
    dB: np.ndarray                  # (N, 3, 3) d B_i / d(E, N, U)_j at the truth, nT/m
    baro_sigma_m: np.ndarray        # (N,) (NaN: no baro at that epoch)
    pos_ecef_m: np.ndarray          # (N, 3)

    @classmethod
    def build(cls, traj, t_s, gmap: GeomagMap, cfg_bound, baro_sigma_m, substep_s: float = 0.1) -> "FlightBound":
        t_s = np.asarray(t_s, float)
        tr = traj.truth(t_s)
        _, grad = gmap.total_and_gradient(tr.lat_rad, tr.lon_rad, tr.alt_m)
        B = gmap.vector_enu_nT(tr.lat_rad, tr.lon_rad, tr.alt_m)
        dB = _vector_gradient(gmap, tr.lat_rad, tr.lon_rad, tr.alt_m)
        bc = pcrb.bound_config(cfg_bound)
        trn = pcrb.transitions_along_truth(traj, t_s, bc, substep_s)
        return cls(t_s, trn, bc.initial_covariance(), bc.layout, grad, B, dB, np.asarray(baro_sigma_m, float),
                   pcrb.ecef_of(tr.lat_rad, tr.lon_rad, tr.alt_m))

    def rows(self, start_s: float, sensor_sigma_nT: float, components: str = "total") -> list:
        """Measurement rows per epoch: baro always, magnetometer from start_s,
        with white sensor noise and the map error in the coloured channel
        (coefficient 1 for the total intensity, the field direction u for
        the components: the simulator's map error is a total-intensity error
        along the field)."""
        lay = self.layout
        n, p, a = lay.dim, lay.sl("pos"), lay.sl("att")
        out = []
        for k, t in enumerate(self.t_s):
            H, r, c = [], [], []
            if np.isfinite(self.baro_sigma_m[k]) and k > 0:
                h = np.zeros(n)
                h[p.start + 2] = 1.0
                H.append(h)
                r.append(self.baro_sigma_m[k] ** 2)
                c.append(0.0)
            if t >= start_s - 1e-9:
                if components == "total":
                    h = np.zeros(n)
                    h[p] = self.grad[k]
                    H.append(h)
                    r.append(sensor_sigma_nT**2)
                    c.append(1.0)
                else:
                    # predicted - measured, ENU: C_est = (I - [phi x]) C_true gives
                    # (I + [phi x]) B(r^) - B(r) = -[B x] phi + dB/dr dr
                    Hm = np.zeros((3, n))
                    Hm[:, p] = self.dB[k]
                    Hm[:, a] = -skew(self.B_enu[k])
                    u = self.B_enu[k] / np.linalg.norm(self.B_enu[k])
                    for i in range(3):
                        H.append(Hm[i])
                        r.append(sensor_sigma_nT**2)
                        c.append(u[i])
            out.append(None if not H else pcrb.Rows(np.array(H), np.array(r), np.array(c)))
        return out

    def bound(self, start_s: float, map_error_rms_nT: float, reading: str, sensor_sigma_nT: float,
              corr_length_m: float, components: str = "total") -> pcrb.HorizontalBound:
        """Horizontal bound for a map error of this RMS: ``correlated`` (the
        simulator's Gaussian-covariance field of length corr_length_m) or
        ``white_uniform`` (independent per sample; bounded with the Gaussian
        of the same variance: a uniform density is not regular, it has no
        finite Fisher information, and every estimator here treats the error
        as Gaussian)."""
        rows = self.rows(start_s, sensor_sigma_nT, components)
        if reading == "correlated":
            cov = pcrb.gaussian_map_error_cov(self.pos_ecef_m, map_error_rms_nT, corr_length_m)
        else:
            cov = pcrb.white_map_error_cov(map_error_rms_nT)
        P = pcrb.linear_gaussian_bound(self.P0, self.transitions, rows, cov)
        return pcrb.horizontal_bound(self.t_s, P, self.layout.sl("pos"), self.grad[:, :2])


def _vector_gradient(gmap: GeomagMap, lat_rad, lon_rad, alt_m, d_m: float = 50.0) -> np.ndarray:
    """d B_enu / d(E, N, U) by central differences of the map (nT/m)."""
    from hyper_nav_aiding.geomag.core.matching import LocalFrame
    out = np.empty((len(lat_rad), 3, 3))
    for k in range(len(lat_rad)):
        fr = LocalFrame(lat_rad[k], lon_rad[k], alt_m[k])
        for j, (de, dn, du) in enumerate(((d_m, 0, 0), (0, d_m, 0), (0, 0, d_m))):
            la1, lo1 = fr.to_geodetic(np.array([de, dn]))
            la0, lo0 = fr.to_geodetic(np.array([-de, -dn]))
            b1 = gmap.vector_enu_nT(la1, lo1, alt_m[k] + du)
            b0 = gmap.vector_enu_nT(la0, lo0, alt_m[k] - du)
            out[k, :, j] = (b1 - b0) / (2 * d_m)
    return out
