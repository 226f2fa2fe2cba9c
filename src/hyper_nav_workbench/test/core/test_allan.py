"""Allan deviation of a simulated static IMU recovers ARW and bias instability."""
import numpy as np
import pytest

from hyper_nav_filter.core import units
from hyper_nav_workbench.core import allan
from hyper_nav_sim.core.imu_model import ImuErrors, corrupt_increments

DT = 0.01                     # 100 Hz
N = int(3 * 3600 / DT)        # 3 hours
# seed 001 white noise levels (0.3 deg/h read as ARW 0.3 deg/sqrt(h); 1e-4 g as
# 100 ug/sqrt(Hz)); bias instabilities of a tactical IMU (our choice).
CFG = {"gyro_arw_deg_per_sqrt_hr": 0.3, "gyro_bias_instability_deg_per_hr": 5.0,
       "accel_vrw_ug_per_sqrt_hz": 100.0, "accel_bias_instability_ug": 50.0}


@pytest.fixture(scope="module")
def static_imu():
    e = ImuErrors.from_config(CFG)
    z = np.zeros((N, 3))
    dth, dv = corrupt_increments(z, z, DT, e, np.random.default_rng(20240601))
    return dth / DT / units.deg_per_hr(1.0), dv / DT / units.ug(1.0)     # deg/h, ug


def test_white_noise_adev_is_n_over_sqrt_tau():
    rng = np.random.default_rng(5)
    y = rng.standard_normal((200_000, 2)) / np.sqrt(DT)                   # N = 1 per sqrt(s)
    taus, adev, n_terms = allan.overlapping_adev(y, DT, [0.01, 0.1, 1.0, 10.0])
    # 2000 s of data: 200 clusters at 10 s, ~5 % (1 sigma) there
    np.testing.assert_allclose(adev, (1.0 / np.sqrt(taus))[:, None] * np.ones((1, 2)), rtol=0.10)
    assert list(n_terms) == [200_000 - 2 * m + 1 for m in (1, 10, 100, 1000)]


def _read(y, arw_unit_per_sqrt_s):
    taus, adev, _ = allan.overlapping_adev(y, DT)
    a = np.sqrt(np.mean(adev**2, axis=1))              # three iid axes pooled
    rel = allan.adev_relative_sigma(taus, N, DT) / np.sqrt(3)
    arw = allan.arw_from_adev(taus, a, tau_max_s=1.0)
    fit = allan.fit_noise_terms(taus, a, rel, tau_range_s=(1.0, N * DT / 10))
    b_min = allan.bias_instability_from_minimum(taus, a, arw=arw, tau_max_s=N * DT / 50)
    return arw / arw_unit_per_sqrt_s, fit["N"] / arw_unit_per_sqrt_s, fit["B"], b_min


def test_gyro_arw_and_bias_instability_recovered(static_imu):
    arw, fit_n, fit_b, b_min = _read(static_imu[0], 60.0)        # deg/h sqrt(s) -> deg/sqrt(h)
    print(f"gyro: ARW {arw:.4f} (fit {fit_n:.4f}) deg/sqrt(h) vs 0.3; B fit {fit_b:.3f}, min {b_min:.3f} deg/h vs 5")
    assert arw == pytest.approx(0.3, rel=0.10)
    assert fit_n == pytest.approx(0.3, rel=0.10)
    assert fit_b == pytest.approx(5.0, rel=0.10)
    assert b_min == pytest.approx(5.0, rel=0.10)


def test_accel_vrw_and_bias_instability_recovered(static_imu):
    vrw, fit_n, fit_b, b_min = _read(static_imu[1], 1.0)         # ug sqrt(s) = ug/sqrt(Hz)
    print(f"accel: VRW {vrw:.2f} (fit {fit_n:.2f}) ug/sqrt(Hz) vs 100; B fit {fit_b:.2f}, min {b_min:.2f} ug vs 50")
    assert vrw == pytest.approx(100.0, rel=0.10)
    assert fit_n == pytest.approx(100.0, rel=0.10)
    assert fit_b == pytest.approx(50.0, rel=0.10)
    assert b_min == pytest.approx(50.0, rel=0.10)
