"""Signal propagation delays: Klobuchar ionosphere and Hopfield troposphere.

Seed 004 eq. 11 gives both (D_iono, D_tropo). Klobuchar follows IS-GPS-200
20.3.3.5.2.5 (Figure 20-4) exactly, in semicircles; it yields the L1 group
delay, scaled to another frequency f by (f_L1 / f)^2 (first-order ionosphere).
BDS broadcasts its own Klobuchar coefficients (BDSA/BDSB); we apply them with
the same GPS algorithm, which is an approximation (the BDS ICD variant uses a
375 km shell and BDT) adequate for simulation.

Hopfield troposphere, seed 004 eq. 11 (E in degrees):
    D = K_d / sin(sqrt(E^2 + 6.25)) + K_w / sin(sqrt(E^2 + 2.25))
    K_d = 1.552e-5 p0/T (h_d - h_u),  h_d = 40136 + 148.72 (T - 273.16) [m]
    K_w = 7.46512e-2 e/T^2 (h_w - h_u), h_w = 11000 m
with p0 [hPa], T [K], e [hPa] at the surface and h_u the receiver height.
The paper's (h_d - h_u) factor is the *linear* reading. Hopfield's refractivity
profile is N(h) = N0 ((h_d - h)/h_d)^4, whose integral from h_u to h_d is
N0 h_d/5 ((h_d - h_u)/h_d)^5; at h_u = 0 both forms coincide (77.6/5 = 15.52,
0.373/5 = 0.0746). For a vehicle at 25-60 km the linear form is badly wrong
(0.66 m zenith at 30 km, while the real atmosphere above 30 km holds ~1 % of
the sea-level pressure, i.e. ~3 cm). Default ``height_model='quartic'``
integrates Hopfield's own profile: 4 mm zenith at 30 km and exactly 0 above
h_d ~ 42 km (dry) / 11 km (wet). ``'linear'`` reproduces the paper literally
(also clipped to 0 above h_d).
"""
from __future__ import annotations

import numpy as np

from hyper_nav_gnss.constants import C_MPS
F_L1_HZ = 1575.42e6
F_B1I_HZ = 1561.098e6
CARRIER_HZ = {"G": F_L1_HZ, "C": F_B1I_HZ}     # GPS L1 C/A, BDS B1I
# Klobuchar coefficients used when no broadcast set is available: the default
# set of RTKLIB (rtkcmn.c ``ion_default``, GPS broadcast of 2004/1/1), a
# moderate-activity ionosphere (~3-8 m vertical L1 delay at midday mid-latitude).
KLOBUCHAR_ALPHA_DEFAULT = (0.1118e-07, -0.7451e-08, -0.5961e-07, 0.1192e-06)
KLOBUCHAR_BETA_DEFAULT = (0.1167e+06, -0.2294e+06, -0.1311e+06, 0.1049e+07)


def klobuchar_delay_m(alpha, beta, lat_rad, lon_rad, el_rad, az_rad, tow_s, freq_hz=F_L1_HZ):
    """Klobuchar slant ionospheric group delay [m] (IS-GPS-200 20.3.3.5.2.5; seed 004 eq. 11).

    alpha [s, s/sc, s/sc^2, s/sc^3], beta [s, s/sc, ...] broadcast coefficients;
    receiver geodetic lat/lon, satellite elevation/azimuth [rad]; tow_s: GPS
    seconds of week (any continuous GPST works, only mod 86400 matters);
    freq_hz: carrier (L1 default; B1I -> x (f_L1/f_B1I)^2 = 1.0184).
    Vectorised over el/az (and lat/lon/tow)."""
    a = np.asarray(alpha, float)
    b = np.asarray(beta, float)
    el_sc = np.asarray(el_rad, float) / np.pi
    psi = 0.0137 / (el_sc + 0.11) - 0.022                        # earth angle [sc]
    phi_i = np.clip(np.asarray(lat_rad) / np.pi + psi * np.cos(az_rad), -0.416, 0.416)
    lam_i = np.asarray(lon_rad) / np.pi + psi * np.sin(az_rad) / np.cos(phi_i * np.pi)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * np.pi)      # geomagnetic lat [sc]
    t = np.mod(4.32e4 * lam_i + np.asarray(tow_s, float), 86400.0)
    F = 1.0 + 16.0 * (0.53 - el_sc) ** 3                         # obliquity factor
    amp = np.maximum(a[0] + phi_m * (a[1] + phi_m * (a[2] + phi_m * a[3])), 0.0)
    per = np.maximum(b[0] + phi_m * (b[1] + phi_m * (b[2] + phi_m * b[3])), 72000.0)
    x = 2.0 * np.pi * (t - 50400.0) / per
    day = np.abs(x) < 1.57
    t_iono = F * (5e-9 + np.where(day, amp * (1.0 - x ** 2 / 2.0 + x ** 4 / 24.0), 0.0))
    return C_MPS * t_iono * (F_L1_HZ / freq_hz) ** 2


def hopfield_delay_m(el_rad, h_rx_m, p0_hpa=1013.25, t0_k=288.15, e0_hpa=11.7,
                     height_model="quartic"):
    """Hopfield tropospheric slant delay [m] (seed 004 eq. 11), receiver at
    height h_rx_m [m] above the surface where p0 [hPa], T0 [K], e0 [hPa] hold.
    Returns (total, dry, wet) arrays; see module docstring for the height model.
    ~2.4 m zenith at sea level for the default standard atmosphere
    (e0 = 11.7 hPa: 50 % humidity at 15 degC)."""
    el_deg = np.rad2deg(np.asarray(el_rad, float))
    h = np.asarray(h_rx_m, float)
    h_d = 40136.0 + 148.72 * (t0_k - 273.16)
    h_w = 11000.0
    kd0 = 1.552e-5 * p0_hpa / t0_k * h_d                          # zenith at h = 0
    kw0 = 7.46512e-2 * e0_hpa / t0_k ** 2 * h_w
    fd = np.clip((h_d - h) / h_d, 0.0, 1.0)
    fw = np.clip((h_w - h) / h_w, 0.0, 1.0)
    if height_model == "quartic":
        fd, fw = fd ** 5, fw ** 5
    elif height_model != "linear":
        raise ValueError("height_model must be 'quartic' or 'linear'")
    dry = kd0 * fd / np.sin(np.deg2rad(np.sqrt(el_deg ** 2 + 6.25)))
    wet = kw0 * fw / np.sin(np.deg2rad(np.sqrt(el_deg ** 2 + 2.25)))
    return dry + wet, dry, wet
