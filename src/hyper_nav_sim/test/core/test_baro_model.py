"""Barometric altimeter: inversion, noise statistics, altitude-equivalent error."""
import numpy as np
import pytest

from hyper_nav_sim.core import baro_model as bm

US76 = bm.us76_pressure_pa       # the project's US76 (atmosphere.py), injected explicitly


def test_us76_pressure_matches_the_standard_table():
    # US Standard Atmosphere 1976 table values at geometric altitude [Pa]
    h = np.array([0.0, 11000.0, 20000.0, 30000.0, 50000.0, 60000.0])
    p = np.array([101325.0, 22700.0, 5529.3, 1197.0, 79.78, 21.96])
    np.testing.assert_allclose(US76(h), p, rtol=2e-3)


def test_inversion_round_trip():
    h = np.linspace(-500.0, 60000.0, 1001)
    back = bm.altitude_from_pressure_m(US76(h), US76)
    np.testing.assert_allclose(back, h, atol=1e-5)
    # with the default pressure function too
    f = bm.default_pressure_fn()
    np.testing.assert_allclose(bm.altitude_from_pressure_m(f(h), f), h, atol=1e-5)


def test_noise_statistics():
    e = bm.BaroErrors.from_config({"pressure_noise_rel_ppm": 200.0, "pressure_noise_pa": 2.0,
                                   "pressure_bias_pa": 5.0, "rate_hz": 10.0})
    h = np.full(100_000, 20000.0)
    p = bm.simulate_baro_pa(h, e, np.random.default_rng(11), US76)
    p_true = US76(20000.0)
    sigma = np.hypot(200e-6 * p_true, 2.0)
    assert p.mean() - p_true == pytest.approx(5.0, abs=4 * sigma / np.sqrt(len(h)))
    assert p.std() == pytest.approx(sigma, rel=0.01)
    # altitude error statistics match the altitude-equivalent sigma
    e0 = bm.BaroErrors.from_config({"pressure_noise_rel_ppm": 200.0, "pressure_noise_pa": 2.0})
    p0 = bm.simulate_baro_pa(h, e0, np.random.default_rng(12), US76)
    dh = bm.altitude_from_pressure_m(p0, US76) - 20000.0
    assert dh.std() == pytest.approx(float(bm.altitude_sigma_m(20000.0, e0, US76)), rel=0.02)


def test_altitude_sigma_grows_with_altitude():
    e = bm.BaroErrors.from_config({"pressure_noise_rel_ppm": 100.0, "pressure_noise_pa": 1.0})
    s10, s30, s60 = bm.altitude_sigma_m(np.array([10000.0, 30000.0, 60000.0]), e, US76)
    print(f"altitude sigma: 10 km {s10:.2f} m, 30 km {s30:.2f} m, 60 km {s60:.1f} m")
    assert s30 > 5 * s10 and s60 > 10 * s30
    # hydrostatic check: sigma_h = sigma_p / (rho g) = sigma_p H / p, H = R T / (g M)
    T30 = 226.509
    H30 = 8.31432 * T30 / (9.80665 * 0.0289644)
    p30 = US76(30000.0)
    g_ratio = (6356766.0 / (6356766.0 + 30000.0)) ** 2       # geometric vs geopotential height
    expected = np.hypot(100e-6 * p30, 1.0) * H30 / p30 / g_ratio
    assert s30 == pytest.approx(expected, rel=1e-3)


def test_validity_limit_and_bad_fields():
    e = bm.BaroErrors.from_config({})
    with pytest.raises(ValueError, match="max_alt_m"):
        bm.simulate_baro_pa(np.array([61000.0]), e, np.random.default_rng(0), US76)
    with pytest.raises(ValueError, match="baro.pressure_noise_pa: must be >= 0"):
        bm.BaroErrors.from_config({"pressure_noise_pa": -1.0})
    with pytest.raises(ValueError, match="baro.pressure_noise: unknown field"):
        bm.BaroErrors.from_config({"pressure_noise": 1.0})
