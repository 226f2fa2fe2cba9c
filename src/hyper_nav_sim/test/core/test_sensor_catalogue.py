"""The sensor catalogue (core.sensor_catalogue): each IMU grade, applied as a
scenario's ``imu: {grade: ...}``, makes the simulator produce its stated
figures: the Allan deviation's white-noise slope reads the grade's ARW/VRW
within 5 % (2000 s at 100 Hz: the ADEV's relative sampling error at
tau <= 10 s is <= 1.6 %, three axes pooled), and the turn-on bias is the
mean rate. Unknown grades are refused with a did-you-mean; overrides beside
``grade`` win."""
import numpy as np
import pytest

from hyper_nav_filter.core import units
from hyper_nav_workbench.core import allan
from hyper_nav_sim.core.imu_model import ImuErrors, corrupt_increments
from hyper_nav_sim.core.scenario import ScenarioError, load_with_settings
from hyper_nav_sim.core.sensor_catalogue import IMU_GRADES, apply_grade, grade_figures

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
