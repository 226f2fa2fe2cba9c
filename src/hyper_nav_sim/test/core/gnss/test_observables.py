"""Pseudorange / Doppler generation: exact rates, Sagnac, clock model."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_gnss.orbits import ephemeris as ep
from hyper_nav_gnss.formats import rinex_nav
from hyper_nav_sim.core.gnss import observables as ob
from hyper_nav_gnss.orbits.constellation import visible_satellites

_spec = importlib.util.spec_from_file_location("gnss_test_data", Path(__file__).with_name("_data.py"))
data = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(data)

T0 = ep.calendar_to_system_s("G", 2023, 1, 1, 1, 0, 0)
R0 = earth.geodetic_to_ecef(np.deg2rad(26.5), np.deg2rad(119.0), 30e3)
V_E = earth.C_n_e(np.deg2rad(26.5), np.deg2rad(119.0)) @ np.array([1500.0, 800.0, 30.0])  # 1700 m/s


@pytest.fixture(scope="module")
def vis():
    ephs, iono = rinex_nav.read_rinex3_nav(data.real_file(data.RINEX3))
    cur = [ep.select_ephemeris(ephs, s, ep.system_time_s(s[0], T0)) for s in sorted({e.sat_id for e in ephs})]
    v = visible_satellites([e for e in cur if e is not None], R0, T0, 5.0)
    return v.ephs, iono


def test_range_rate_equals_finite_difference(vis):
    """Straight-line receiver (1700 m/s, 30 km): geometric range rate vs central
    difference of geometric ranges (h = 0.0625 s) agrees to < 1e-4 m/s for all
    satellites; ignoring d(tau)/dt (g = 1) would err by up to ~4 cm/s.
    Pseudorange rate also equals d(pseudorange)/dt incl. clocks (< 1e-4 m/s)."""
    ephs, _ = vis
    h = 0.0625
    kw = dict(rx_clk_bias_m=1234.0, rx_clk_drift_mps=25.0, tropo=False)
    o = ob.compute_observables(ephs, T0, R0, V_E, **kw)
    op = ob.compute_observables(ephs, T0 + h, R0 + V_E * h, V_E, rx_clk_bias_m=1234.0 + 25.0 * h,
                                rx_clk_drift_mps=25.0, tropo=False)
    om = ob.compute_observables(ephs, T0 - h, R0 - V_E * h, V_E, rx_clk_bias_m=1234.0 - 25.0 * h,
                                rx_clk_drift_mps=25.0, tropo=False)
    fd = (op.geometric_range_m - om.geometric_range_m) / (2 * h)
    assert np.max(np.abs(o.geometric_rate_mps - fd)) < 1e-4
    fd_pr = (op.pseudorange_m - om.pseudorange_m) / (2 * h)
    assert np.max(np.abs(o.pseudorange_rate_mps - fd_pr)) < 1e-4
    np.testing.assert_allclose(o.doppler_hz, -o.pseudorange_rate_mps * o.carrier_hz / ep.C_MPS)
    assert np.max(np.abs(o.geometric_doppler_hz)) > 5000.0   # 1700 m/s + satellite motion


def test_sagnac_and_light_time(vis):
    """Transit 67-90 ms; Sagnac term |R3 r - r| projected on the LOS is up to
    we r_sat r_rx / c = 65 m for a GEO: check range with vs without rotation
    differs by 5 m < max |d| < 70 m (measured 51 m, C05) and that tau = range/c to 1e-12 s."""
    ephs, _ = vis
    r_s, v_s, cb, cd, tau, R, dR = ob.satellite_states_at_reception(ephs, T0, R0)
    rr = np.einsum("kij,kj->ki", R, r_s)
    rng = np.linalg.norm(rr - R0, axis=1)
    np.testing.assert_allclose(tau, rng / ep.C_MPS, atol=1e-12)
    assert np.all((tau > 0.064) & (tau < 0.14))
    d = rng - np.linalg.norm(r_s - R0, axis=1)
    assert np.max(np.abs(d)) < 70.0 and np.max(np.abs(d)) > 5.0


def test_noise_iono_tropo_terms(vis):
    """Noise has the seed-004 sigma (0.11 + 0.13 exp(-E/4deg) m): normalised
    residuals over 30 draws (~1000 samples) have std 1 +- 0.1; iono (Klobuchar) 1-30 m and
    B1I/L1 scaled; tropo at 30 km < 5 cm."""
    ephs, iono = vis
    clean = ob.compute_observables(ephs, T0, R0, V_E, iono=iono)
    rng = np.random.default_rng(1)
    z = np.concatenate([(ob.compute_observables(ephs, T0, R0, V_E, iono=iono, rng=rng).pseudorange_m
                         - clean.pseudorange_m) / clean.pr_sigma_m for _ in range(30)])
    assert abs(np.std(z) - 1.0) < 0.1
    assert np.all((clean.iono_m > 1.0) & (clean.iono_m < 30.0))
    assert np.all(clean.tropo_m < 0.05)
    np.testing.assert_allclose(ob.pr_sigma_m(0.0), 0.24)


def test_clock_model_statistics():
    """h0 = 2e-19, h-2 = 2e-20 -> S_b = 0.0090 m^2/s, S_d = 0.355 m^2/s^3; the
    sampled drift variance after 10 s (2000 runs) matches S_d*10 within 10 %."""
    cm = ob.ClockModel()
    Q = cm.q_matrix(1.0)
    assert Q[1, 1] == pytest.approx(2 * np.pi ** 2 * 2e-20 * ep.C_MPS ** 2)
    rng = np.random.default_rng(7)
    t = np.arange(11.0)
    d = np.array([cm.simulate(t, rng)[1][-1] for _ in range(2000)])
    assert np.var(d) == pytest.approx(Q[1, 1] * 10, rel=0.1)


def test_stacked_light_time_equals_per_satellite(vis):
    """``satellite_states_at_reception`` evaluates each system and orbit kind
    in one pass (``EphemerisStack``): the same states as the per-satellite
    light-time iteration with one record at a time (real GPS and BDS records,
    BDS GEO included), to 1e-6 m, 1e-9 m/s and 1e-15 s (array and scalar
    trigonometry may differ in the last bit)."""
    ephs, _ = vis
    assert {e.system for e in ephs} == {"G", "C"} and any(e.is_geo for e in ephs)
    r_s, v_s, cb, cd, tau, R, dR = ob.satellite_states_at_reception(ephs, T0, R0)
    for k, e in enumerate(ephs):
        w = ep.constants(e.system)[1]
        t_sys = ep.system_time_s(e.system, T0)
        t = 0.075
        for _ in range(4):
            r = ep.satellite_position_ecef(e, t_sys, -t)[0]
            c, s = np.cos(w * t), np.sin(w * t)
            t = np.linalg.norm(np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ r - R0) / ep.C_MPS
        r, v, b, d = ep.satellite_position_ecef(e, t_sys, -t)
        assert tau[k] == pytest.approx(t, abs=1e-15)
        np.testing.assert_allclose(r_s[k], r, rtol=0, atol=1e-6)
        np.testing.assert_allclose(v_s[k], v, rtol=0, atol=1e-9)
        assert cb[k] == pytest.approx(b, abs=1e-15) and cd[k] == pytest.approx(d, abs=1e-18)
    from hyper_nav_gnss.orbits.ephemeris import EphemerisStack
    with pytest.raises(ValueError, match="one system"):
        EphemerisStack(ephs)
