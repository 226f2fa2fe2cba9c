"""IMU error model: backward compatibility, config parsing, each error term."""
import numpy as np
import pytest

from hyper_nav_filter.core import units
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.imu_model import (ARCSEC, ImuErrors, ImuErrorState, corrupt_increments,
                                          gm_allan_variance, imu_epochs, markov_sum_components, quantize)
from hyper_nav_sim.core.scenario import load_scenario

# seed 001 (HWIL boost-glide), section 4: gyro 3 deg/h, 100 ppm, 0.3 deg/h white;
# accelerometer 1 mg, 100 ppm, 1e-4 g white
SEED001 = {"gyro_bias_deg_per_hr": 3.0, "gyro_scale_factor_ppm": 100.0, "gyro_arw_deg_per_sqrt_hr": 0.3,
           "accel_bias_ug": 1000.0, "accel_scale_factor_ppm": 100.0, "accel_vrw_ug_per_sqrt_hz": 100.0}


def test_old_model_is_reproduced_bit_for_bit():
    """Only the four original fields set: the same draws and numbers as the
    original bias + white-noise model."""
    sc = load_scenario("default")
    e = ImuErrors.from_scenario(sc)
    traj = sc.trajectory()
    dt = 1.0 / sc["imu.rate_hz"]
    t = imu_epochs(20.0, sc["imu.rate_hz"])
    dth, dv = traj.imu_increments(t, dt)
    got = corrupt_increments(dth, dv, dt, e, sc.rng("imu"))
    rng = sc.rng("imu")
    n = len(t)
    ref_th = (dth + units.deg_per_hr(sc["imu.gyro_bias_deg_per_hr"]) * dt
              + rng.standard_normal((n, 3)) * units.deg_per_sqrt_hr(sc["imu.gyro_arw_deg_per_sqrt_hr"]) * np.sqrt(dt))
    ref_v = (dv + units.ug(sc["imu.accel_bias_ug"]) * dt
             + rng.standard_normal((n, 3)) * units.ug_per_sqrt_hz(sc["imu.accel_vrw_ug_per_sqrt_hz"]) * np.sqrt(dt))
    np.testing.assert_array_equal(got[0], ref_th)
    np.testing.assert_array_equal(got[1], ref_v)
    stream = simulate.imu_stream(sc, traj)            # the existing caller still works
    assert stream.dtheta_b_rad.shape == (15000, 3)


def test_from_config_units_seed001():
    e = ImuErrors.from_config({**SEED001, "rate_hz": 500.0})
    np.testing.assert_allclose(e.gyro_bias_b_radps, 3.0 * np.pi / 180 / 3600, rtol=1e-15)
    np.testing.assert_allclose(e.gyro_scale_factor, 1e-4, rtol=1e-15)
    assert e.gyro_arw_rad_per_sqrt_s == pytest.approx(0.3 * np.pi / 180 / 60, rel=1e-15)
    np.testing.assert_allclose(e.accel_bias_b_mps2, 1e-3 * 9.80665, rtol=1e-15)
    assert e.accel_vrw_mps_per_sqrt_s == pytest.approx(1e-4 * 9.80665, rel=1e-15)
    assert np.all(e.gyro_misalignment_rad == 0) and e.gyro_quantum_rad == 0.0
    empty = ImuErrors.from_config({})
    assert np.all(empty.gyro_bias_b_radps == 0) and empty.accel_vrw_mps_per_sqrt_s == 0.0


@pytest.mark.parametrize("d,message", [
    ({"gyro_bias_deg_per_h": 1.0}, "imu.gyro_bias_deg_per_h: unknown field"),
    ({"gyro_arw_deg_per_sqrt_hr": "low"}, "imu.gyro_arw_deg_per_sqrt_hr: expected a number"),
    ({"gyro_arw_deg_per_sqrt_hr": -1.0}, "imu.gyro_arw_deg_per_sqrt_hr: must be >= 0"),
    ({"accel_bias_ug": [1.0, 2.0]}, "imu.accel_bias_ug: expected a number or a list of 3"),
    ({"gyro_markov_tau_s": 0.0}, "imu.gyro_markov_tau_s: must be > 0"),
    ({"gyro_misalignment_arcsec": [[1, 0, 0], [0, 0, 0], [0, 0, 0]]}, "imu.gyro_misalignment_arcsec: diagonal"),
    ({"accel_misalignment_mrad": [1, 2, 3]}, "imu.accel_misalignment_mrad: expected a 3x3"),
    ({"gyro_misalignment_arcsec": 0, "gyro_misalignment_mrad": 0}, "imu.gyro_misalignment_arcsec: give either"),
    ({"bias_instability_band_s": [10.0, 1.0]}, "imu.bias_instability_band_s: need 0 < min < max"),
])
def test_bad_config_field_is_named(d, message):
    with pytest.raises(ValueError) as exc:
        ImuErrors.from_config(d)
    assert message in str(exc.value)


def test_scale_factor_and_misalignment_exact():
    m_arcsec = [[0.0, 20.0, -10.0], [5.0, 0.0, 30.0], [-40.0, 15.0, 0.0]]
    e = ImuErrors.from_config({"gyro_scale_factor_ppm": [100.0, -50.0, 200.0], "gyro_misalignment_arcsec": m_arcsec,
                               "accel_scale_factor_ppm": 100.0, "accel_misalignment_mrad": m_arcsec})
    rng = np.random.default_rng(1)
    dth, dv = rng.standard_normal((100, 3)) * 0.01, rng.standard_normal((100, 3))
    got_th, got_v = corrupt_increments(dth, dv, 0.01, e, rng)
    Tg = np.eye(3) + np.diag([100e-6, -50e-6, 200e-6]) + np.array(m_arcsec) * ARCSEC
    Ta = np.eye(3) * (1 + 100e-6) + np.array(m_arcsec) * 1e-3
    np.testing.assert_allclose(got_th, dth @ Tg.T, rtol=0, atol=1e-17)
    np.testing.assert_allclose(got_v, dv @ Ta.T, rtol=0, atol=1e-15)


def test_gauss_markov_sigma_and_correlation_time():
    tau, sigma_dph, dt = 2.0, 1.0, 0.01
    e = ImuErrors.from_config({"gyro_markov_sigma_deg_per_hr": sigma_dph, "gyro_markov_tau_s": tau})
    n = 400_000                                # 4000 s = 2000 correlation times per axis
    z = np.zeros((n, 3))
    dth, _ = corrupt_increments(z, z, dt, e, np.random.default_rng(2))
    b = dth / dt / units.deg_per_hr(1.0)
    assert b.std() == pytest.approx(sigma_dph, rel=0.05)          # ~1.3 % statistical (1 sigma)
    lag = int(tau / dt)
    rho = np.mean([np.corrcoef(b[:-lag, i], b[lag:, i])[0, 1] for i in range(3)])
    assert rho == pytest.approx(np.exp(-1.0), abs=0.03)


def test_markov_sum_allan_floor_is_flat_at_0664_B():
    """Closed-form check of the bias-instability construction: the Allan
    deviation of the Markov sum is 0.664 B within 2 % over [20 T_min, T_max / 20]."""
    sig, taus_c = markov_sum_components(1.0, (0.1, 1e5))
    t = np.logspace(np.log10(2.0), np.log10(5e3), 30)
    adev = np.sqrt(sum(gm_allan_variance(t, s, tc) for s, tc in zip(sig, taus_c)))
    np.testing.assert_allclose(adev, 0.6643, rtol=0.02)


def test_quantization_residual_is_carried():
    q_rad = 1e-6
    e = ImuErrors.from_config({"gyro_quantum_urad": 1.0, "accel_quantum_mm_per_s": 1.0})
    rng = np.random.default_rng(3)
    dth = 3.3e-7 + 1e-7 * rng.standard_normal((10_000, 3))        # a third of a quantum per sample
    dv = 0.0123 + 1e-4 * rng.standard_normal((10_000, 3))
    out_th, out_v = corrupt_increments(dth, dv, 0.01, e, rng)
    counts = out_th / q_rad
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
    err = np.abs(np.cumsum(out_th, axis=0) - np.cumsum(dth, axis=0))
    assert err.max() <= 0.5 * q_rad * (1 + 1e-6)                  # bounded, no accumulation
    assert np.abs(np.cumsum(out_v - dv, axis=0)).max() <= 0.5e-3 * (1 + 1e-6)
    # streaming in two chunks with a carried state gives the same output
    st = ImuErrorState()
    a = corrupt_increments(dth[:3333], dv[:3333], 0.01, e, rng, st)[0]
    b = corrupt_increments(dth[3333:], dv[3333:], 0.01, e, rng, st)[0]
    np.testing.assert_allclose(np.vstack([a, b]), out_th, atol=1e-15)
    single, _ = quantize(dth, q_rad)
    np.testing.assert_allclose(single, out_th, atol=1e-15)


def test_all_terms_together_keep_bias_and_noise_levels():
    e = ImuErrors.from_config({**SEED001, "gyro_markov_sigma_deg_per_hr": 0.5, "gyro_markov_tau_s": 100.0,
                               "gyro_bias_instability_deg_per_hr": 0.5, "gyro_quantum_urad": 0.1})
    n, dt = 200_000, 0.002
    z = np.zeros((n, 3))
    dth, dv = corrupt_increments(z, z, dt, e, np.random.default_rng(4))
    g = dth / dt / units.deg_per_hr(1.0)
    # mean over 400 s = 3 deg/h + the slow terms, whose stationary sigma is
    # sqrt(GM^2 + sum of the Markov-sum component variances)
    sig_c, _ = markov_sum_components(0.5, e.bias_instability_band_s)
    slow_sigma = np.sqrt(0.5**2 + np.sum(sig_c**2))
    assert np.all(np.abs(g.mean(axis=0) - 3.0) < 4.0 * slow_sigma)
    assert g.std(axis=0) == pytest.approx(np.full(3, 0.3 * 60 / np.sqrt(dt)), rel=0.02)
    a = dv / dt
    np.testing.assert_allclose(a.std(axis=0) * np.sqrt(dt), units.ug_per_sqrt_hz(100.0), rtol=0.02)
