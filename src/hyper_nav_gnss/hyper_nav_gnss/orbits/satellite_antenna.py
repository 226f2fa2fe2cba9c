"""Satellite antenna phase-centre offset (PCO) in ECEF: what turns a
precise orbit's centre of mass into the antenna phase centre the code
ranges refer to (RTKLIB 2.4.3 ``satantoff``; IGS ANTEX convention).

Body frame of the nominal yaw-steering attitude (the ANTEX satellite frame
of GPS, Galileo, BeiDou IGSO/MEO; Montenbruck et al. 2015, GPS Solutions
19:321, sec. 2):
    e_z = -r / |r| (toward the Earth's centre),
    e_y = unit(e_z x e_sun) with e_sun the unit vector satellite -> Sun
          (the solar panels' rotation axis),
    e_x = e_y x e_z (completing the right-handed frame, toward the Sun's
          half-plane).
Offset of the phase centre: ``d = x e_x + y e_y + z e_z`` for the ANTEX
x, y, z of one frequency; for an ionosphere-free pair ``d = a1 d1 + a2 d2``
with the pair's coefficients (a1 = f1^2/(f1^2-f2^2), a2 = 1 - a1).
Not modelled: the noon/midnight turns and eclipse yaw manoeuvres (x/y
offsets are decimetres; the z part, which holds the metres, does not
depend on the yaw), BeiDou GEO orbit-normal attitude (the same: only x/y).

Sun position: the low-precision series of Montenbruck & Gill, Satellite
Orbits (2000) eq. 3.38-3.41 (0.01 deg, 1 % in distance; the longitude
moved from the J2000 equinox to the equinox of date by 1.3972 deg per
century), turned into ECEF by the GMST alone (GPST taken as UT1: 0.075 deg
since 2017; nutation and polar motion ignored). Against RTKLIB's
``sunmoonpos``: 0.34-0.48 deg in longitude, 0.15 deg in latitude over 2021-22
(tested < 0.5 deg); RTKLIB applies the precession from J2000 to a mean
longitude already of date (0.29 deg in 2021). 0.5 deg moves an x offset of
0.4 m by 3.5 mm.
"""
from __future__ import annotations

import numpy as np

JD_GPS_EPOCH = 2444244.5            # 1980-01-06 00:00
AU_M = 149597870700.0


def sun_position_ecef(t_gpst_s) -> np.ndarray:
    """Sun position [m] (n, 3) in ECEF at continuous GPST seconds (module docstring)."""
    t = np.atleast_1d(np.asarray(t_gpst_s, float))
    jd = JD_GPS_EPOCH + t / 86400.0
    T = (jd - 2451545.0) / 36525.0
    M = np.deg2rad(357.5256 + 35999.049 * T)
    lam = np.deg2rad(282.9400 + 1.3972 * T) + M + np.deg2rad((6892.0 * np.sin(M) + 72.0 * np.sin(2 * M)) / 3600.0)
    r = (149.619e9 - 2.499e9 * np.cos(M) - 0.021e9 * np.cos(2 * M))
    eps = np.deg2rad(23.43929111)
    x, y, z = r * np.cos(lam), r * np.sin(lam) * np.cos(eps), r * np.sin(lam) * np.sin(eps)
    th = np.deg2rad(np.mod(280.46061837 + 360.98564736629 * (jd - 2451545.0), 360.0))
    return np.stack([np.cos(th) * x + np.sin(th) * y, -np.sin(th) * x + np.cos(th) * y, z], axis=1)


def body_axes(r_sat_e_m, r_sun_e_m):
    """e_x, e_y, e_z (each (n, 3)) of the nominal yaw-steering frame (module docstring)."""
    r = np.atleast_2d(r_sat_e_m)
    ez = -r / np.linalg.norm(r, axis=1, keepdims=True)
    es = np.atleast_2d(r_sun_e_m) - r
    es = es / np.linalg.norm(es, axis=1, keepdims=True)
    ey = np.cross(ez, es)
    ey = ey / np.linalg.norm(ey, axis=1, keepdims=True)
    ex = np.cross(ey, ez)
    return ex, ey, ez


def pco_ecef_m(pco_body_m, r_sat_e_m, t_gpst_s) -> np.ndarray:
    """The phase-centre offset (n, 3) [m] in ECEF of body-frame offsets
    ``pco_body_m`` (n, 3) (x, y, z) of satellites at ``r_sat_e_m`` (n, 3), at GPST ``t_gpst_s`` (n,)."""
    ex, ey, ez = body_axes(r_sat_e_m, sun_position_ecef(t_gpst_s))
    p = np.atleast_2d(pco_body_m)
    return p[:, :1] * ex + p[:, 1:2] * ey + p[:, 2:3] * ez
