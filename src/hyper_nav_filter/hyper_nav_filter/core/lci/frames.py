"""Launch frame and the ECEF / LECI / LCI / geodetic conversions (seed 001 section 2).

Frames (seed 001 section 2.1, letters as in the paper):
  e  ECEF (WGS-84).
  t  LECI, launch Earth-centred inertial: origin at the Earth's centre, axes
     coincident with ECEF at the launch epoch t0 and fixed in inertial space
     afterwards, so C_e_t(t) = Rz(omega_ie (t - t0)) (a rotation about the
     common z axis, the Earth's spin axis).
  g  LCEF, launch-centred Earth-fixed: origin at the launch point, rotating
     with the Earth.
  a  LCI, launch-centred inertial: coincident with LCEF at t0 and then fixed
     in inertial space (origin = where the launch point was at t0).
  b  body, FLU (project convention, REP-103).
  n  local-level ENU at the vehicle (output frame).

LCI axes (the convention of seed 001 eq. 2 and the launch-vehicle literature,
e.g. Chen Kejun "Ballistic missile trajectory" / Zhang et al. [12]; the
extracted text lost the matrix, so it is reconstructed here):
  x_a  in the launch-point horizontal plane (tangent to the WGS-84 ellipsoid,
       i.e. normal to the *geodetic* vertical), along the launch azimuth A0,
       A0 measured clockwise from geodetic north;
  y_a  up along the geodetic vertical (ellipsoid normal) of the launch point;
  z_a  = x_a cross y_a, completing the right-handed set (points east for a
       northward launch, A0 = 0).
In launch-point ENU: x_a = (sin A0, cos A0, 0), y_a = (0, 0, 1),
z_a = (cos A0, -sin A0, 0). With this, eq. 5 reads
omega_ie_a = Omega (cos B0 cos A0, sin B0, -cos B0 sin A0).

Position r_a is relative to the LCI origin (the launch point at t0); the
geocentric vector is R0_a + r_a with R0_a = C_e_a(t0) r0_e (eq. 4). Velocity
v_a = dr_a/dt is the *inertial* velocity (eq. 6), so converting an ECEF
(ground) velocity adds the Earth-rotation term omega_ie x r (section 4.3).

DCM naming follows the project: ``C_x_y`` maps x-frame components to
y-frame components, v_y = C_x_y v_x.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hyper_nav_gnss import earth

OMEGA_IE_RADPS = earth.OMEGA_IE_RADPS


def C_n_e_vec(lat_rad, lon_rad):
    """ENU -> ECEF DCMs, vectorised: shape (..., 3, 3) (columns E, N, U)."""
    lat_rad, lon_rad = np.broadcast_arrays(np.asarray(lat_rad, float), np.asarray(lon_rad, float))
    sl, cl = np.sin(lat_rad), np.cos(lat_rad)
    so, co = np.sin(lon_rad), np.cos(lon_rad)
    z = np.zeros_like(sl)
    rows = [np.stack([-so, -sl * co, cl * co], axis=-1),
            np.stack([co, -sl * so, cl * so], axis=-1),
            np.stack([z, cl, sl], axis=-1)]
    return np.stack(rows, axis=-2)


def C_e_t(dt_since_launch_s):
    """ECEF -> LECI DCM(s), Rz(omega_ie dt): shape (3, 3) or (..., 3, 3)."""
    ang = OMEGA_IE_RADPS * np.asarray(dt_since_launch_s, float)
    c, s = np.cos(ang), np.sin(ang)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([c, -s, z], axis=-1),
                     np.stack([s, c, z], axis=-1),
                     np.stack([z, z, o], axis=-1)], axis=-2)


def _mv(M, v):
    """Matrix(es) times vector(s) with broadcasting over leading axes."""
    return np.einsum("...ij,...j->...i", M, v)


@dataclass(frozen=True)
class LaunchFrame:
    """The launch point and azimuth that define the LCI frame.

    lat_rad, lon_rad, alt_m: geodetic (WGS-84) launch point; azimuth_rad: A0,
    clockwise from north; t0_s: launch epoch in the navigation time base (the
    epoch at which LECI = ECEF and LCI = LCEF).
    """
    lat_rad: float
    lon_rad: float
    alt_m: float
    azimuth_rad: float
    t0_s: float = 0.0
    # derived, constant (eqs. 2-5)
    r0_e_m: np.ndarray = field(init=False, repr=False)
    C_n0_a: np.ndarray = field(init=False, repr=False)
    C_t_a: np.ndarray = field(init=False, repr=False)
    R0_a_m: np.ndarray = field(init=False, repr=False)
    spin_axis_a: np.ndarray = field(init=False, repr=False)
    omega_ie_a_radps: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        A = self.azimuth_rad
        sa, ca = np.sin(A), np.cos(A)
        # rows: x_a, y_a, z_a expressed in launch-point ENU -> this is C_n0_a
        C_n0_a = np.array([[sa, ca, 0.0], [0.0, 0.0, 1.0], [ca, -sa, 0.0]])
        C_e_n0 = earth.C_n_e(self.lat_rad, self.lon_rad).T
        C_t_a = C_n0_a @ C_e_n0                       # eq. 2 (= C_e_g at t0 = C_t_a)
        r0_e = earth.geodetic_to_ecef(self.lat_rad, self.lon_rad, self.alt_m)   # eq. 3
        object.__setattr__(self, "r0_e_m", r0_e)
        object.__setattr__(self, "C_n0_a", C_n0_a)
        object.__setattr__(self, "C_t_a", C_t_a)
        object.__setattr__(self, "R0_a_m", C_t_a @ r0_e)                       # eq. 4
        axis = C_t_a @ np.array([0.0, 0.0, 1.0])
        object.__setattr__(self, "spin_axis_a", axis)
        object.__setattr__(self, "omega_ie_a_radps", OMEGA_IE_RADPS * axis)    # eq. 5

    @classmethod
    def from_degrees(cls, lat_deg, lon_deg, alt_m, azimuth_deg, t0_s=0.0) -> "LaunchFrame":
        return cls(np.deg2rad(lat_deg), np.deg2rad(lon_deg), float(alt_m), np.deg2rad(azimuth_deg), t0_s)

    # ---- rotations ---------------------------------------------------------------
    def C_e_a(self, t_s):
        """ECEF -> LCI DCM at time t: C_t_a Rz(omega_ie (t - t0)); (..., 3, 3)."""
        return self.C_t_a @ C_e_t(np.asarray(t_s, float) - self.t0_s)

    def C_n_a(self, lat_rad, lon_rad, t_s):
        """Local ENU at (lat, lon) -> LCI at time t; (..., 3, 3)."""
        return self.C_e_a(t_s) @ C_n_e_vec(lat_rad, lon_rad)

    # ---- ECEF <-> LCI (section 4.3) -------------------------------------------
    def ecef_to_lci(self, r_e_m, v_e_mps, t_s):
        """ECEF position and Earth-relative velocity at time t -> (r_a_m, v_a_mps).

        Section 4.3: r_t = C_e_t r_e, v_t = C_e_t (v_e + omega_ie x r_e) (LECI),
        then r_a = C_t_a r_t - R0_a, v_a = C_t_a v_t. Vectorised over a leading
        axis (r_e, v_e (N, 3), t (N,))."""
        r_e_m, v_e_mps = np.asarray(r_e_m, float), np.asarray(v_e_mps, float)
        C = self.C_e_a(t_s)
        w = np.array([0.0, 0.0, OMEGA_IE_RADPS])
        r_a = _mv(C, r_e_m) - self.R0_a_m
        v_a = _mv(C, v_e_mps + np.cross(w, r_e_m))
        return r_a, v_a

    def lci_to_ecef(self, r_a_m, v_a_mps, t_s):
        """Inverse of :meth:`ecef_to_lci`: (r_e_m, v_e_mps) Earth-relative."""
        r_a_m, v_a_mps = np.asarray(r_a_m, float), np.asarray(v_a_mps, float)
        C_a_e = np.swapaxes(self.C_e_a(t_s), -1, -2)
        w = np.array([0.0, 0.0, OMEGA_IE_RADPS])
        r_e = _mv(C_a_e, r_a_m + self.R0_a_m)
        v_e = _mv(C_a_e, v_a_mps) - np.cross(w, r_e)
        return r_e, v_e

    def ecef_position_to_lci(self, r_e_m, t_s):
        return _mv(self.C_e_a(t_s), np.asarray(r_e_m, float)) - self.R0_a_m

    def lci_position_to_ecef(self, r_a_m, t_s):
        return _mv(np.swapaxes(self.C_e_a(t_s), -1, -2), np.asarray(r_a_m, float) + self.R0_a_m)

    # ---- geodetic / ENU <-> LCI (initialisation and output conversion) -------------
    def geodetic_to_lci(self, lat_rad, lon_rad, alt_m, vel_enu_mps, C_b_n, t_s):
        """Geodetic position, ENU ground velocity and C_b_n at time t ->
        (r_a_m, v_a_mps, C_b_a). Vectorised over a leading time axis."""
        C_n_e = C_n_e_vec(lat_rad, lon_rad)
        r_e = earth.geodetic_to_ecef(lat_rad, lon_rad, alt_m)
        v_e = _mv(C_n_e, np.asarray(vel_enu_mps, float))
        r_a, v_a = self.ecef_to_lci(r_e, v_e, t_s)
        C_b_a = self.C_e_a(t_s) @ C_n_e @ np.asarray(C_b_n, float)
        return r_a, v_a, C_b_a

    def lci_to_geodetic(self, r_a_m, v_a_mps, C_b_a, t_s):
        """LCI solution at time t -> (lat_rad, lon_rad, alt_m, vel_enu_mps, C_b_n):
        the output conversion to local-level navigation quantities (seed 001
        section 5.1, ref. [21]). Singularity-free: returns C_b_n, Euler angles
        are left to the consumer (attitude.C_b_n_to_euler)."""
        r_e, v_e = self.lci_to_ecef(r_a_m, v_a_mps, t_s)
        lat, lon, alt = earth.ecef_to_geodetic(r_e)
        C_e_n = np.swapaxes(C_n_e_vec(lat, lon), -1, -2)
        vel_enu = _mv(C_e_n, v_e)
        C_b_n = C_e_n @ np.swapaxes(self.C_e_a(t_s), -1, -2) @ np.asarray(C_b_a, float)
        return lat, lon, alt, vel_enu, C_b_n

    def cov_ecef_to_lci(self, cov_e, t_s):
        """Rotate a 3x3 ECEF covariance into LCI at time t."""
        C = self.C_e_a(t_s)
        return C @ cov_e @ C.T

    def cov_enu_to_lci(self, cov_n, lat_rad, lon_rad, t_s):
        """Rotate a 3x3 covariance given in the local ENU frame at (lat, lon) into LCI."""
        C = self.C_n_a(lat_rad, lon_rad, t_s)
        return C @ cov_n @ C.T
