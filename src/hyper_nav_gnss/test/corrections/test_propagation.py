"""Klobuchar and Hopfield delays against closed-form values of the models."""
from __future__ import annotations

import numpy as np
import pytest

from hyper_nav_gnss.corrections.propagation import C_MPS, F_B1I_HZ, F_L1_HZ, hopfield_delay_m, klobuchar_delay_m

ALPHA_2021 = [0.9313e-08, 0.1490e-07, -0.5960e-07, -0.1192e-06]   # brdc1180.21n header
BETA_2021 = [0.8806e05, 0.4915e05, -0.1311e06, -0.3277e06]


def test_klobuchar_zenith_noon_and_night_closed_form():
    """Zenith (E = 90 deg -> F = 1 + 16 (0.03)^3 = 1.000432, psi = 0.000459 sc),
    alpha = [a0, 0, 0, 0]: at IPP local time 14:00 (x = 0) the delay is
    c F (5 ns + a0) exactly; at local midnight only the 5 ns night floor remains."""
    a0 = 3.0e-8
    F = 1.0 + 16.0 * 0.03 ** 3
    lon = 0.0
    # az = 0 => IPP longitude = user longitude, local time = tow (mod day)
    noon = klobuchar_delay_m([a0, 0, 0, 0], [72000.0, 0, 0, 0], 0.3, lon, np.pi / 2, 0.0, 50400.0)
    assert noon == pytest.approx(C_MPS * F * (5e-9 + a0), rel=1e-12)       # 10.49 m
    night = klobuchar_delay_m([a0, 0, 0, 0], [72000.0, 0, 0, 0], 0.3, lon, np.pi / 2, 0.0, 0.0)
    assert night == pytest.approx(C_MPS * F * 5e-9, rel=1e-12)             # 1.4996 m


def test_klobuchar_real_coefficients_magnitude_and_b1i_scaling():
    """brdc1180.21n coefficients, receiver 26.5N 119E, 06:00 UTC (~14 h local):
    zenith delay 4.6 m, at 10 deg elevation x2.8 (obliquity factor F(10 deg) = 2.80
    times a slightly different IPP). B1I = L1 x (1575.42/1561.098)^2 = 1.01843."""
    lat, lon = np.deg2rad(26.5), np.deg2rad(119.0)
    tow = 3 * 86400 + 6 * 3600.0
    z = klobuchar_delay_m(ALPHA_2021, BETA_2021, lat, lon, np.pi / 2, 0.0, tow)
    assert 3.0 < z < 8.0
    low = klobuchar_delay_m(ALPHA_2021, BETA_2021, lat, lon, np.deg2rad(10.0), np.pi, tow)
    assert 2.3 < low / z < 3.3
    b1 = klobuchar_delay_m(ALPHA_2021, BETA_2021, lat, lon, np.pi / 2, 0.0, tow, freq_hz=F_B1I_HZ)
    assert b1 / z == pytest.approx((F_L1_HZ / F_B1I_HZ) ** 2, rel=1e-12)
    assert (F_L1_HZ / F_B1I_HZ) ** 2 == pytest.approx(1.01843, abs=1e-5)


def test_hopfield_sea_level_zenith_and_mapping():
    """Standard atmosphere 1013.25 hPa, 288.15 K, e = 11.7 hPa: dry zenith
    1.552e-5*1013.25/288.15*42365.6 = 2.312 m, wet 0.1158 m, total 2.43 m
    (within the 2.3-2.5 m textbook range); at 10 deg elevation ~5.6x zenith."""
    tot, dry, wet = hopfield_delay_m(np.pi / 2, 0.0)
    h_d = 40136.0 + 148.72 * (288.15 - 273.16)
    assert dry == pytest.approx(1.552e-5 * 1013.25 / 288.15 * h_d / np.sin(np.deg2rad(np.hypot(90, 2.5))),
                                rel=1e-12)
    assert 2.30 < dry < 2.33 and 0.10 < wet < 0.13 and 2.3 < tot < 2.5
    t10, *_ = hopfield_delay_m(np.deg2rad(10.0), 0.0)
    assert 5.0 < t10 / tot < 6.0


def test_hopfield_vanishes_at_vehicle_altitude():
    """Quartic (integrated Hopfield profile): 30 km -> zenith (12.37/42.37)^5 * 2.31
    = 4.8 mm, 0 above 42.4 km; the paper's linear form would give 0.65 m at 30 km."""
    z30, dry30, wet30 = hopfield_delay_m(np.pi / 2, 30e3)
    assert wet30 == 0.0
    assert 0.002 < z30 < 0.01
    z45, *_ = hopfield_delay_m(np.deg2rad(5.0), np.array([45e3, 60e3]))
    np.testing.assert_array_equal(z45, 0.0)
    lin30, *_ = hopfield_delay_m(np.pi / 2, 30e3, height_model="linear")
    assert 0.6 < lin30 < 0.7
    # monotone decrease with height
    zs, *_ = hopfield_delay_m(np.pi / 2, np.linspace(0, 45e3, 50))
    assert np.all(np.diff(zs) <= 0)
