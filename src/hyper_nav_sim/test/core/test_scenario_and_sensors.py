"""Scenario validation and sensor models."""
import numpy as np
import pytest

from hyper_nav_filter.core import units
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.mag_model import wmm_field_enu_nT
from hyper_nav_sim.core.scenario import ScenarioError, load_scenario, validate


def test_default_scenario_has_the_papers_numbers():
    sc = load_scenario("default")
    assert sc["imu.rate_hz"] == 50.0 and sc["gnss.rate_hz"] == 10.0 and sc["duration_s"] == 300.0
    assert sc["filter.initial_error.pos_enu_m"] == [5.0, 5.0, 10.0]


@pytest.mark.parametrize("mutate,message", [
    (lambda d: d["imu"].pop("rate_hz"), "missing required field 'imu.rate_hz'"),
    (lambda d: d["imu"].__setitem__("rate_hz", "fifty"), "imu.rate_hz: expected a number, got 'fifty'"),
    (lambda d: d["imu"].__setitem__("rate_hz", -5), "imu.rate_hz: must be > 0"),
    (lambda d: d.__setitem__("seed", 1.5), "seed: expected an integer"),
    (lambda d: d["maneuvers"][1].__setitem__("type", "barrel"), "maneuvers[1].type"),
    (lambda d: d["filter"]["config"].__setitem__("gyro_bias_tau_s", "x"), "gyro_bias_tau_s"),
])
def test_bad_fields_are_named(mutate, message):
    data = load_scenario("default").data
    mutate(data)
    with pytest.raises(ScenarioError) as exc:
        validate(data, "test.yaml")
    assert message in str(exc.value)


def test_imu_noise_statistics_match_configuration():
    sc = load_scenario("default")
    traj = sc.trajectory()
    exact = simulate.imu_stream(sc, traj, error_free=True)
    noisy = simulate.imu_stream(sc, traj)
    dt = exact.dt_s
    e_g = (noisy.dtheta_b_rad - exact.dtheta_b_rad) / dt
    e_a = (noisy.dvel_b_mps - exact.dvel_b_mps) / dt
    n = len(e_g)
    np.testing.assert_allclose(e_g.mean(axis=0), units.deg_per_hr(sc["imu.gyro_bias_deg_per_hr"]),
                               atol=5 * units.deg_per_sqrt_hr(sc["imu.gyro_arw_deg_per_sqrt_hr"]) / np.sqrt(dt * n))
    np.testing.assert_allclose(e_a.mean(axis=0), units.ug(sc["imu.accel_bias_ug"]),
                               atol=5 * units.ug_per_sqrt_hz(100.0) / np.sqrt(dt * n))
    assert e_g.std(axis=0) * np.sqrt(dt) == pytest.approx(np.full(3, units.deg_per_sqrt_hr(sc["imu.gyro_arw_deg_per_sqrt_hr"])), rel=0.03)
    assert e_a.std(axis=0) * np.sqrt(dt) == pytest.approx(np.full(3, units.ug_per_sqrt_hz(100.0)), rel=0.03)


def test_wmm_field_is_real():
    # pygeomag WMM at 44N 110E, 25 km: total intensity about 57,000 nT (ros2-on-pypi notes)
    b = wmm_field_enu_nT(np.deg2rad(44.0), np.deg2rad(110.0), 25000.0, 2025.5)
    assert 54000 < np.linalg.norm(b) < 60000
    assert b[1] > 0 and b[2] < 0        # points north and down in the northern hemisphere


def test_gnss_noise_matches_sigma():
    sc = load_scenario("default")
    traj = sc.trajectory()
    g = simulate.gnss_stream(sc, traj)
    tr = traj.truth(g.t_s)
    from hyper_nav_gnss import earth
    d = earth.position_error_enu_m(g.lat_rad, g.lon_rad, g.alt_m, tr.lat_rad, tr.lon_rad, tr.alt_m)
    assert d.std(axis=0) == pytest.approx([5.0, 5.0, 5.0], rel=0.05)
    assert (g.vel_enu_mps - tr.vel_enu_mps).std(axis=0) == pytest.approx([0.1, 0.1, 0.1], rel=0.05)
