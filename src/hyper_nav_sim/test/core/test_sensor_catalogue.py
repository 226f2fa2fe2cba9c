"""The sensor catalogue (core.sensor_catalogue): each IMU grade, applied as a
scenario's ``imu: {grade: ...}``, makes the simulator produce its stated
figures: the Allan deviation's white-noise slope reads the grade's ARW/VRW
within 5 % (2000 s at 100 Hz: the ADEV's relative sampling error at
tau <= 10 s is <= 1.6 %, three axes pooled), and the turn-on bias is the
mean rate. The GNSS receiver, magnetometer and barometer grades likewise:
their fixes, field readings and pressures scatter by the grade's sigmas
(within 5 sampling sigmas), the barometer's bias is its mean offset and its
ceiling the US76 altitude of its range's low end. Unknown grades are refused
with a did-you-mean naming the block; overrides beside ``grade`` win."""
import numpy as np
import pytest

from hyper_nav_filter.core import units
from hyper_nav_workbench.core import allan
from hyper_nav_sim.core.imu_model import ImuErrors, corrupt_increments
from hyper_nav_sim.core.scenario import ScenarioError, load_with_settings
from hyper_nav_filter.core.atmosphere import pressure_Pa
from hyper_nav_gnss import earth
from hyper_nav_sim.core.baro_model import BaroErrors, simulate_baro_pa
from hyper_nav_sim.core.gnss_model import simulate_fixes
from hyper_nav_sim.core.mag_model import simulate_magnetometer_T
from hyper_nav_sim.core.sensor_catalogue import CATALOGUE, IMU_GRADES, apply_grade, grade_figures

RATE, T = 100.0, 2000.0


@pytest.mark.parametrize("grade", sorted(IMU_GRADES))
def test_grade_produces_its_allan_deviations(grade):
    f = grade_figures(grade)
    err = ImuErrors.from_config(apply_grade({"grade": grade}))
    n, dt = int(RATE * T), 1.0 / RATE
    dth, dv = corrupt_increments(np.zeros((n, 3)), np.zeros((n, 3)), dt, err, np.random.default_rng(39))
    for inc, stated, to_si in ((dth, f["gyro_arw_deg_per_sqrt_hr"], float(units.deg_per_sqrt_hr(1.0))),
                               (dv, f["accel_vrw_ug_per_sqrt_hz"], float(units.ug_per_sqrt_hz(1.0)))):
        rate = inc / dt
        got = []
        for ax in range(3):
            taus, adev, _ = allan.overlapping_adev(rate[:, ax], dt)
            got.append(allan.arw_from_adev(taus, adev, tau_max_s=10.0))
        np.testing.assert_allclose(np.mean(got), stated * to_si, rtol=0.05, err_msg=grade)
    # the turn-on bias is the mean rate (+, -, + per axis), within 5 sigma of the white noise's mean
    mean = dth.sum(axis=0) / T
    b = float(units.deg_per_hr(f["gyro_bias_deg_per_hr"])) * np.array([1.0, -1.0, 1.0])
    tol = 5 * float(units.deg_per_sqrt_hr(f["gyro_arw_deg_per_sqrt_hr"])) / np.sqrt(T)
    np.testing.assert_allclose(mean, b, atol=tol)


def test_scenario_takes_a_grade_with_overrides_and_refuses_unknown_names():
    sc = load_with_settings("default", ["imu={rate_hz: 50.0, grade: tactical, accel_vrw_ug_per_sqrt_hz: 7.0}"])
    assert sc["imu.gyro_arw_deg_per_sqrt_hr"] == pytest.approx(0.1)
    assert sc["imu.gyro_bias_deg_per_hr"] == pytest.approx([0.75, -0.75, 0.75])
    assert sc["imu.accel_vrw_ug_per_sqrt_hz"] == pytest.approx(7.0)          # the override wins
    with pytest.raises(ScenarioError, match="did you mean 'tactical'"):
        load_with_settings("default", ["imu={rate_hz: 50.0, grade: tactcal}"])
    # every figure names its source
    for g in IMU_GRADES.values():
        for k, v in g.items():
            if k != "description":
                assert isinstance(v, tuple) and v[1], k


# ---- GNSS receiver, magnetometer and barometer grades -------------------------------------------
GRADED = ["gnss={grade: ublox_m8}", "magnetometer={grade: rm3100, epoch_decimal_year: 2025.5}",
          "barometer={grade: bmp388}"]


def _std_ok(samples, stated, n):
    """Sample standard deviation of n draws within 5 of its own sampling sigma (stated / sqrt(2 n))."""
    np.testing.assert_allclose(np.std(samples, axis=0), stated, atol=5 * np.max(stated) / np.sqrt(2 * n))


@pytest.mark.parametrize("grade", sorted(CATALOGUE["gnss"]))
def test_gnss_grade_fixes_scatter_by_its_sigmas(grade):
    """Fixes drawn on the default flight at the grade's figures: the ENU position and velocity errors
    against the truth have the grade's per-axis sigmas (3000 fixes)."""
    sc = load_with_settings("default", [f"gnss={{grade: {grade}}}"])
    f = grade_figures(grade, "gnss")
    assert sc["gnss.pos_sigma_enu_m"] == pytest.approx(f["pos_sigma_enu_m"]) and sc["gnss.rate_hz"] == f["rate_hz"]
    t = np.arange(3000) * 0.1
    g = simulate_fixes(sc.trajectory(), t, np.array(f["pos_sigma_enu_m"]), np.array(f["vel_sigma_enu_mps"]),
                       np.zeros(3), np.random.default_rng(7))
    tr = sc.trajectory().truth(t)
    d = np.array([earth.position_error_enu_m(g.lat_rad[k], g.lon_rad[k], g.alt_m[k], tr.lat_rad[k], tr.lon_rad[k],
                                             tr.alt_m[k]) for k in range(len(t))])
    _std_ok(d, f["pos_sigma_enu_m"], len(t))
    _std_ok(g.vel_enu_mps - tr.vel_enu_mps, f["vel_sigma_enu_mps"], len(t))


@pytest.mark.parametrize("grade", sorted(CATALOGUE["magnetometer"]))
def test_magnetometer_grade_noise(grade):
    sc = load_with_settings("default", [f"magnetometer={{grade: {grade}, epoch_decimal_year: 2025.5}}"])
    f = grade_figures(grade, "magnetometer")
    assert sc["magnetometer.noise_nT"] == f["noise_nT"] and sc["magnetometer.rate_hz"] == f["rate_hz"]
    t = np.arange(3000) / f["rate_hz"]
    traj = sc.trajectory()
    noisy = simulate_magnetometer_T(traj, t, 2025.5, f["noise_nT"], np.random.default_rng(3))
    clean = simulate_magnetometer_T(traj, t, 2025.5, 0.0, np.random.default_rng(3))
    _std_ok((noisy - clean) * 1e9, np.full(3, f["noise_nT"]), len(t))


@pytest.mark.parametrize("grade", sorted(CATALOGUE["barometer"]))
def test_barometer_grade_noise_bias_and_ceiling(grade):
    """The grade's noise and bias in simulated pressure (4000 readings at 5 km), and its ceiling where US76
    pressure falls to the low end of its range (300 hPa: 9.2 km for the BMP388; 10 mbar: 31 km for the MS5611)."""
    sc = load_with_settings("default", [f"barometer={{grade: {grade}}}"])
    f = grade_figures(grade, "barometer")
    err = BaroErrors.from_config(sc.data["barometer"], prefix="barometer")
    assert (err.pressure_noise_pa, err.pressure_bias_pa, err.max_alt_m) == (f["pressure_noise_pa"],
                                                                            f["pressure_bias_pa"], f["max_alt_m"])
    alt = np.full(4000, 5000.0)
    d = simulate_baro_pa(alt, err, np.random.default_rng(5)) - pressure_Pa(alt)
    _std_ok(d, f["pressure_noise_pa"], len(alt))
    assert abs(np.mean(d) - f["pressure_bias_pa"]) < 5 * f["pressure_noise_pa"] / np.sqrt(len(alt))
    low_pa = {"bmp388": 30000.0, "ms5611": 1000.0}[grade]
    assert float(pressure_Pa(f["max_alt_m"])) == pytest.approx(low_pa, rel=2e-4)        # rounded to the metre


def test_every_block_takes_a_grade_and_refuses_unknown_names_naming_the_block():
    sc = load_with_settings("default", GRADED + ["gnss={grade: ublox_m8, rate_hz: 2.0}"])
    assert sc["gnss.rate_hz"] == 2.0 and sc["gnss.pos_sigma_enu_m"][0] == pytest.approx(2.5 / 1.1774, rel=1e-4)
    assert sc["magnetometer.noise_nT"] == 15.0 and sc.data["barometer"]["max_alt_m"] == grade_figures(
        "bmp388", "barometer")["max_alt_m"]
    for setting, match in (("gnss={grade: ublox_m9}", r"gnss.grade: unknown grade 'ublox_m9'; did you mean 'ublox_m8'"),
                           ("barometer={grade: ms5661}", r"barometer.grade: unknown grade 'ms5661'; did you mean "
                                                         r"'ms5611'")):
        with pytest.raises(ScenarioError, match=match):
            load_with_settings("default", [setting])
    for block, grades in CATALOGUE.items():                       # every figure names its source
        for name, g in grades.items():
            assert g.get("description"), (block, name)
            for k, v in g.items():
                if k != "description":
                    assert isinstance(v, tuple) and v[1], (block, name, k)
