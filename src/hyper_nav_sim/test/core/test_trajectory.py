"""Kinematic truth: rates and specific force consistent with the trajectory."""
import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import C_b_n_to_euler
from hyper_nav_sim.core.scenario import load_scenario


@pytest.fixture(scope="module")
def traj():
    return load_scenario("default").trajectory()


@pytest.mark.parametrize("t", [25.0, 95.0, 115.0, 160.0, 215.0, 260.0])
def test_omega_and_specific_force_match_finite_differences(traj, t):
    h = 1e-4
    tr = traj.truth([t - h, t, t + h])
    # omega_nb_b from dC/dt = C [omega x]
    C0, C1, C2 = tr.C_b_n
    Cdot = (C2 - C0) / (2 * h)
    W = C1.T @ Cdot
    omega_nb_fd = np.array([W[2, 1], W[0, 2], W[1, 0]])
    w_in = earth.omega_ie_n(tr.lat_rad[1]) + earth.omega_en_n(tr.lat_rad[1], tr.alt_m[1], tr.vel_enu_mps[1])
    omega_ib_fd = omega_nb_fd + C1.T @ w_in
    np.testing.assert_allclose(tr.omega_ib_b_radps[1], omega_ib_fd, atol=1e-8)
    # f_b from finite-difference acceleration and the navigation equation
    vdot = (tr.vel_enu_mps[2] - tr.vel_enu_mps[0]) / (2 * h)
    w_ie = earth.omega_ie_n(tr.lat_rad[1])
    w_en = earth.omega_en_n(tr.lat_rad[1], tr.alt_m[1], tr.vel_enu_mps[1])
    f_n = vdot + np.cross(2 * w_ie + w_en, tr.vel_enu_mps[1]) - earth.gravity_n(tr.lat_rad[1], tr.alt_m[1])
    np.testing.assert_allclose(tr.f_b_mps2[1], C1.T @ f_n, atol=1e-5)


def test_position_is_the_integral_of_velocity(traj):
    t = np.array([100.0, 100.5])
    tr = traj.truth(t)
    mid = traj.truth([100.25])
    rates = earth.geodetic_rates(mid.lat_rad[0], mid.alt_m[0], mid.vel_enu_mps[0])
    assert (tr.lat_rad[1] - tr.lat_rad[0]) == pytest.approx(rates[0] * 0.5, rel=1e-5)
    assert (tr.alt_m[1] - tr.alt_m[0]) == pytest.approx(rates[2] * 0.5, rel=1e-4, abs=1e-3)


def test_start_matches_the_scenario(traj):
    tr = traj.truth([0.0])
    assert np.rad2deg(tr.lat_rad[0]) == pytest.approx(30.011)
    assert np.rad2deg(tr.lon_rad[0]) == pytest.approx(120.094)
    assert tr.alt_m[0] == pytest.approx(30000.0)
    np.testing.assert_allclose(tr.vel_enu_mps[0], [0.0, 1700.0, 0.0], atol=1e-9)
    roll, pitch, heading = C_b_n_to_euler(tr.C_b_n[0])
    assert np.rad2deg(pitch) == pytest.approx(2.0)      # angle of attack, level flight
    assert heading == pytest.approx(0.0, abs=1e-12) or heading == pytest.approx(2 * np.pi)


def test_maneuvers_happen(traj):
    tr = traj.truth(np.array([0.0, 45.0, 185.0, 245.0, 275.0]))
    assert tr.alt_m[1] > 30000.0 + 1000.0                       # climbed
    assert np.rad2deg(tr.heading_rad[2]) == pytest.approx(30.0, abs=1e-6)   # turned right 30 deg
    assert np.rad2deg(tr.heading_rad[3]) % 360 == pytest.approx(345.0, abs=1e-6)
    assert np.linalg.norm(tr.vel_enu_mps[4]) == pytest.approx(1800.0, abs=1e-6)
    g_load = np.linalg.norm(traj.truth(np.arange(0, 300, 0.5)).f_b_mps2, axis=1).max() / 9.80665
    assert 3.0 < g_load < 10.0
