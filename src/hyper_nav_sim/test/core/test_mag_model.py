"""Magnetometer: WMM unchanged without errors, hard/soft iron exact, map-error RMS."""
import numpy as np
import pytest

from hyper_nav_sim.core import mag_model as mm
from hyper_nav_sim.core.imu_model import imu_epochs
from hyper_nav_sim.core.scenario import load_scenario


@pytest.fixture(scope="module")
def flight():
    sc = load_scenario("default")
    traj = sc.trajectory()
    return sc, traj, imu_epochs(30.0, 2.0)


def test_zero_errors_leave_the_wmm_model_unchanged(flight):
    sc, traj, t = flight
    ref = mm.simulate_magnetometer_T(traj, t, 2025.5, 5.0, np.random.default_rng(7))
    zero = mm.MagnetometerErrors.from_config({"rate_hz": 10.0, "noise_nT": 5.0, "epoch_decimal_year": 2025.5})
    got = mm.simulate_magnetometer_T(traj, t, 2025.5, 5.0, np.random.default_rng(7), zero)
    np.testing.assert_array_equal(got, ref)
    # and without noise it is the WMM field rotated into the body
    clean = mm.simulate_magnetometer_T(traj, t, 2025.5, 0.0, np.random.default_rng(7), zero)
    tr = traj.truth(t)
    for k in (0, len(t) - 1):
        b_n = mm.wmm_field_enu_nT(tr.lat_rad[k], tr.lon_rad[k], tr.alt_m[k], 2025.5)
        np.testing.assert_allclose(clean[k], tr.C_b_n[k].T @ b_n * 1e-9, rtol=0, atol=1e-20)


def test_hard_and_soft_iron_applied_exactly(flight):
    sc, traj, t = flight
    S = [[1.02, 0.01, -0.005], [0.01, 0.97, 0.002], [-0.005, 0.002, 1.01]]
    h = [120.0, -80.0, 35.0]
    e = mm.MagnetometerErrors.from_config({"hard_iron_b_nT": h, "soft_iron": S})
    clean = mm.simulate_magnetometer_T(traj, t, 2025.5, 0.0, np.random.default_rng(0))
    got = mm.simulate_magnetometer_T(traj, t, 2025.5, 0.0, np.random.default_rng(0), e)
    np.testing.assert_allclose(got * 1e9, (clean * 1e9) @ np.array(S).T + h, rtol=1e-14, atol=1e-9)


@pytest.mark.parametrize("level_nT", [0.1, 1.0, 5.0, 10.0])       # seed 003 Table 1 / section 4.1 levels
def test_map_error_rms_over_a_large_area(level_nT):
    e = mm.MagnetometerErrors.from_config({"map_error_rms_nT": level_nT, "map_error_corr_length_m": 20000.0,
                                           "map_error_seed": 3})
    f = e.map_error_field()
    # seed 003's map area: 40N-48N, 109E-112E at 25 km, widened to 30N-50N, 100E-125E (~2200 x 2200 km)
    lat, lon = np.meshgrid(np.deg2rad(np.linspace(30, 50, 250)), np.deg2rad(np.linspace(100, 125, 250)))
    d = f.value_nT(lat, lon, 25000.0)
    assert np.sqrt(np.mean(d**2)) == pytest.approx(level_nT, rel=0.10)
    assert abs(d.mean()) < 0.1 * level_nT


def test_map_error_is_spatially_correlated():
    f = mm.MapErrorField(1.0, 20000.0, seed=5)
    lat0, lon0 = np.deg2rad(np.linspace(30, 50, 4000)), np.deg2rad(110.0)
    step_m = 6.37e6 * np.deg2rad(20.0 / 3999)                  # ~556 m between points, north
    d = f.value_nT(lat0, lon0, 25000.0)
    for sep_m in (5000.0, 20000.0, 60000.0):
        lag = int(round(sep_m / step_m))
        rho = np.corrcoef(d[:-lag], d[lag:])[0, 1]
        assert rho == pytest.approx(np.exp(-0.5 * (sep_m / 20000.0) ** 2), abs=0.15)


def test_map_error_enters_the_measured_intensity(flight):
    sc, traj, t = flight
    e = mm.MagnetometerErrors.from_config({"map_error_rms_nT": 10.0, "map_error_seed": 1})
    clean = mm.simulate_magnetometer_T(traj, t, 2025.5, 0.0, np.random.default_rng(0))
    got = mm.simulate_magnetometer_T(traj, t, 2025.5, 0.0, np.random.default_rng(0), e)
    tr = traj.truth(t)
    expected = e.map_error_field().value_nT(tr.lat_rad, tr.lon_rad, tr.alt_m)
    np.testing.assert_allclose(np.linalg.norm(got, axis=1) * 1e9 - np.linalg.norm(clean, axis=1) * 1e9,
                               expected, atol=1e-6)


@pytest.mark.parametrize("d,message", [
    ({"hard_iron_b_nT": [1, 2]}, "magnetometer.hard_iron_b_nT: expected a list of 3"),
    ({"soft_iron": [[1, 0], [0, 1]]}, "magnetometer.soft_iron: expected a 3x3"),
    ({"map_error_rms_nT": -1}, "magnetometer.map_error_rms_nT: must be >= 0"),
    ({"map_error_corr_length_m": 0}, "magnetometer.map_error_corr_length_m: must be > 0"),
    ({"hard_iron": [0, 0, 0]}, "magnetometer.hard_iron: unknown field"),
])
def test_bad_config_field_is_named(d, message):
    with pytest.raises(ValueError) as exc:
        mm.MagnetometerErrors.from_config(d)
    assert message in str(exc.value)


def test_white_uniform_map_error_is_per_sample_and_bounded(flight):
    """The other reading of seed 003's "+-level": independent per sample,
    uniform in [-sqrt(3) rms, sqrt(3) rms], along the field (a total-intensity
    error); the same draws for the same seed."""
    sc, traj, _ = flight
    t = imu_epochs(300.0, 1.0)
    e = mm.MagnetometerErrors.from_config({"map_error_rms_nT": 2.0, "map_error_model": "white_uniform",
                                           "map_error_seed": 5})
    got = mm.simulate_magnetometer_T(traj, t, 2025.5, 0.0, np.random.default_rng(0), e)
    clean = mm.simulate_magnetometer_T(traj, t, 2025.5, 0.0, np.random.default_rng(0))
    d = (np.linalg.norm(got, axis=1) - np.linalg.norm(clean, axis=1)) * 1e9
    assert np.max(np.abs(d)) <= np.sqrt(3.0) * 2.0 + 1e-6
    assert np.std(d) == pytest.approx(2.0, rel=0.15)
    assert abs(np.corrcoef(d[:-1], d[1:])[0, 1]) < 0.2                      # no memory
    again = mm.simulate_magnetometer_T(traj, t, 2025.5, 0.0, np.random.default_rng(0), e)
    np.testing.assert_array_equal(got, again)
    with pytest.raises(ValueError, match="magnetometer.map_error_model"):
        mm.MagnetometerErrors.from_config({"map_error_model": "pink"})
