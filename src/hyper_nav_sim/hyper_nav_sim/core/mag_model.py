"""Magnetometer model: the World Magnetic Model field (pygeomag) at the true
position and epoch, rotated into body axes, plus white noise.

pygeomag returns north/east/down components in nT for geodetic latitude,
longitude and altitude in km; they are mapped to ENU (E, N, -D), rotated to
body FLU with C_n_b and converted to tesla for sensor_msgs/MagneticField.
Hard/soft iron and map errors come with issue #3.
"""
from __future__ import annotations

import numpy as np
from pygeomag import GeoMag

_GEOMAG = GeoMag()


def wmm_field_enu_nT(lat_rad, lon_rad, alt_m, decimal_year):
    """WMM main field in ENU [nT] at one geodetic point."""
    r = _GEOMAG.calculate(glat=float(np.rad2deg(lat_rad)), glon=float(np.rad2deg(lon_rad)),
                          alt=float(alt_m) / 1000.0, time=float(decimal_year))
    return np.array([r.y, r.x, -r.z])


def simulate_magnetometer_T(traj, t_s, decimal_year, noise_nT, rng):
    """Body-frame field [T] at epochs t_s, shape (N, 3)."""
    tr = traj.truth(t_s)
    out = np.empty((len(t_s), 3))
    for k in range(len(t_s)):
        b_n = wmm_field_enu_nT(tr.lat_rad[k], tr.lon_rad[k], tr.alt_m[k], decimal_year)
        out[k] = tr.C_b_n[k].T @ b_n
    out += rng.standard_normal(out.shape) * noise_nT
    return out * 1e-9
