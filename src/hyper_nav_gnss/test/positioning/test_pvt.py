"""WLS PVT on noise-free observables: closes the loop with observables.py."""
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
from hyper_nav_gnss.positioning.pvt import solve_pvt

_spec = importlib.util.spec_from_file_location("gnss_test_data", Path(__file__).parents[1] / "_data.py")
data = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(data)

T0 = ep.calendar_to_system_s("G", 2023, 1, 1, 1, 0, 0)
LAT, LON = np.deg2rad(26.5), np.deg2rad(119.0)
R0 = earth.geodetic_to_ecef(LAT, LON, 30e3)
V_E = earth.C_n_e(LAT, LON) @ np.array([1500.0, 800.0, 30.0])      # |v| = 1700 m/s


@pytest.fixture(scope="module")
def sky():
    ephs, iono = rinex_nav.read_rinex3_nav(data.real_file(data.RINEX3))
    cur = [ep.select_ephemeris(ephs, s, ep.system_time_s(s[0], T0)) for s in sorted({e.sat_id for e in ephs})]
    return visible_satellites([e for e in cur if e is not None], R0, T0, 5.0).ephs, iono


@pytest.mark.parametrize("systems", [("G",), ("C",), ("G", "C")])
def test_noise_free_pvt_exact(sky, systems):
    """Noise-free, iono on and removed with the same model, tropo on and removed,
    receiver clock 3 km / 50 m/s: position error < 1 cm, velocity < 1 mm/s,
    clock to < 1 cm and ISB ~ 0. Measured: ~1e-7 m / 1e-7 m/s (all cases)."""
    ephs = [e for e in sky[0] if e.system in systems]
    iono = sky[1]
    o = ob.compute_observables(ephs, T0, R0, V_E, rx_clk_bias_m=3000.0, rx_clk_drift_mps=50.0, iono=iono)
    sol = solve_pvt(ephs, o.t_tag_s, o.pseudorange_m, o.pr_sigma_m, o.pseudorange_rate_mps,
                    o.rate_sigma_mps, iono_m=o.iono_m, tropo_m=o.tropo_m)
    assert np.linalg.norm(sol.r_e_m - R0) < 0.01
    assert np.linalg.norm(sol.v_e_mps - V_E) < 1e-3
    assert sol.clk_bias_m == pytest.approx(3000.0, abs=0.01)
    assert sol.clk_drift_mps == pytest.approx(50.0, abs=1e-3)
    assert all(abs(b) < 0.01 for b in sol.isb_m.values())
    assert sol.iterations <= 8
    assert np.max(np.abs(sol.residuals_m)) < 0.01
    assert 0.4 < sol.dop["pdop"] < 6.0 and sol.dop["hdop"] < sol.dop["pdop"]


def test_noisy_pvt_consistent_with_covariance(sky):
    """GPS only, seed-004 noise, 60 epochs: normalised position error squared
    (NEES over 3 dof, via the returned covariance) averages 3 +- 1, and the
    velocity error is < 0.5 m/s."""
    ephs = [e for e in sky[0] if e.system == "G"]
    rng = np.random.default_rng(3)
    nees, verr = [], []
    for _ in range(60):
        o = ob.compute_observables(ephs, T0, R0, V_E, rx_clk_bias_m=10.0, tropo=False, rng=rng)
        s = solve_pvt(ephs, o.t_tag_s, o.pseudorange_m, o.pr_sigma_m, o.pseudorange_rate_mps, o.rate_sigma_mps)
        e = s.r_e_m - R0
        nees.append(e @ np.linalg.solve(s.cov_pos_clk[:3, :3], e))
        verr.append(np.linalg.norm(s.v_e_mps - V_E))
    assert 2.0 < np.mean(nees) < 4.0
    assert max(verr) < 0.5
