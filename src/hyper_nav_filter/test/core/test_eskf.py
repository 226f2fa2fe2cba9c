"""ESKF: the linearized error model against the mechanization itself, and
the update against the closed-form Kalman solution."""
import numpy as np
import pytest

from hyper_nav_filter.core import earth
from hyper_nav_filter.core.attitude import attitude_error_n_rad, rotvec_to_C
from hyper_nav_filter.core.config import ConfigError, FilterConfig
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.measurements import GnssPosition, ModelContext
from hyper_nav_filter.core.nav_state import ImuSample, NavState
from hyper_nav_sim.core.scenario import load_scenario

CFG = FilterConfig()
DURATION_S = 7200.0
LAY = CFG.layout


def perturbed(truth: NavState, dx) -> NavState:
    """Estimate = truth + error, in the filter's error conventions."""
    s = truth.copy()
    s.C_b_n = rotvec_to_C(-dx[LAY.sl("att")]) @ truth.C_b_n
    s.vel_enu_mps = truth.vel_enu_mps + dx[LAY.sl("vel")]
    d_e, d_n, d_u = dx[LAY.sl("pos")]
    r_m, r_n = earth.radii(truth.lat_rad)
    s.lat_rad += d_n / (r_m + truth.alt_m)
    s.lon_rad += d_e / ((r_n + truth.alt_m) * np.cos(truth.lat_rad))
    s.alt_m += d_u
    s.gyro_bias_b_radps = truth.gyro_bias_b_radps + dx[LAY.sl("bg")]
    s.accel_bias_b_mps2 = truth.accel_bias_b_mps2 + dx[LAY.sl("ba")]
    return s


def error(est: NavState, truth: NavState):
    return np.concatenate([
        attitude_error_n_rad(est.C_b_n, truth.C_b_n), est.vel_enu_mps - truth.vel_enu_mps,
        earth.position_error_enu_m(est.lat_rad, est.lon_rad, est.alt_m, truth.lat_rad, truth.lon_rad, truth.alt_m),
        est.gyro_bias_b_radps - truth.gyro_bias_b_radps, est.accel_bias_b_mps2 - truth.accel_bias_b_mps2])


def test_transition_matrix_matches_mechanization_during_a_turn():
    """Propagate truth and a perturbed state through the same IMU data for
    2 s of a hypersonic 30-degree turn: the difference must follow Phi dx0."""
    traj = load_scenario("default").trajectory()
    rate, t0, n = 100.0, 150.0, 200
    dt = 1.0 / rate
    t = t0 + np.arange(1, n + 1) * dt
    dth, dv = traj.imu_increments(t, dt)
    tr = traj.truth([t0])
    truth = NavState(t0, tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0], tr.vel_enu_mps[0], tr.C_b_n[0])
    dx0 = np.concatenate([np.deg2rad([0.01, -0.01, 0.02]), [0.2, -0.3, 0.1], [3.0, -4.0, 5.0],
                          np.deg2rad([1.0, -1.0, 2.0]) / 3600, [2e-3, -1e-3, 3e-3]])
    kf_t = ErrorStateKF(CFG, truth, np.eye(LAY.dim))
    kf_e = ErrorStateKF(CFG, perturbed(truth, dx0), np.zeros((LAY.dim, LAY.dim)))
    Phi_total = np.eye(LAY.dim)
    for k in range(n):
        imu = ImuSample(t[k], dt, dth[k], dv[k])
        kf_t.P = np.eye(LAY.dim)
        kf_t.cfg = CFG
        from hyper_nav_filter.core.error_model import discretize, system_matrices
        F, G, Qc = system_matrices(kf_t.state, dv[k] / dt, dth[k] / dt, LAY, CFG)
        Phi, _ = discretize(F, G, Qc, dt)
        Phi_total = Phi @ Phi_total
        kf_t.predict(imu)
        kf_e.predict(imu)
    actual = error(kf_e.state, kf_t.state)
    predicted = Phi_total @ dx0
    scale = np.abs(dx0).reshape(5, 3).max(axis=1).repeat(3)
    for name in LAY.names:
        s = LAY.sl(name)
        np.testing.assert_allclose(predicted[s], actual[s], atol=0.02 * np.abs(actual[s]).max() + 1e-3 * scale[s].max(),
                                   err_msg=f"block {name}")


def test_update_equals_closed_form_kalman_and_gates_outliers():
    s = NavState(0.0, 0.5, 2.0, 1000.0, np.array([10.0, 20.0, 0.0]), np.eye(3))
    P0 = CFG.initial_covariance()
    kf = ErrorStateKF(CFG, s.copy(), P0)
    R = np.diag([25.0, 25.0, 25.0])
    r_m, r_n = earth.radii(s.lat_rad)
    meas = GnssPosition(0.0, s.lat_rad + 4.0 / (r_m + s.alt_m), s.lon_rad, s.alt_m - 6.0, R)
    ctx = ModelContext(np.zeros(3), np.zeros(3), 0.0)
    z, H, Rm = meas.model(kf.state, LAY, ctx)
    np.testing.assert_allclose(z, [0.0, -4.0, 6.0], atol=1e-5)
    res = kf.update(meas.kind, 0.0, z, H, Rm)
    assert res.accepted
    K = P0 @ H.T @ np.linalg.inv(H @ P0 @ H.T + R)
    np.testing.assert_allclose(kf.P, (np.eye(LAY.dim) - K @ H) @ P0, atol=1e-12)
    dx = K @ z
    # north moved by -dx_n toward the measurement
    assert kf.state.lat_rad == pytest.approx(s.lat_rad - dx[LAY.sl("pos")][1] / (r_m + s.alt_m), abs=1e-15)
    assert kf.state.alt_m == pytest.approx(s.alt_m - dx[LAY.sl("pos")][2], abs=1e-9)
    assert np.all(np.linalg.eigvalsh(kf.P) > 0)
    # a 1 km outlier fails the chi-square gate and is counted, state untouched
    before = kf.state.copy()
    bad = GnssPosition(0.0, s.lat_rad + 1000.0 / (r_m + s.alt_m), s.lon_rad, s.alt_m, R)
    res = kf.update(bad.kind, 0.0, *bad.model(kf.state, LAY, ctx))
    assert not res.accepted and kf.n_rejected == 1 and res.nis > 1000
    assert kf.state.lat_rad == before.lat_rad


def test_config_errors_name_the_field():
    with pytest.raises(ConfigError, match="gyro_bias_tau_s"):
        FilterConfig(gyro_bias_tau_s=-1.0)
    with pytest.raises(ConfigError, match="init_pos_sigma_m"):
        FilterConfig.from_dict({"init_pos_sigma_m": [1.0, 2.0]})
    with pytest.raises(ConfigError, match="accel_vrw_ug_per_sqrt_hz"):
        FilterConfig.from_dict({"accel_vrw_ug_per_sqrt_hz": "lots"})
    with pytest.raises(ConfigError, match="state_blocks"):
        FilterConfig(state_blocks=("att", "vel", "pos", "warp"))


def test_covariance_stays_symmetric_positive_definite_over_two_hours():
    """A 2-hour hypersonic cruise (10 Hz IMU, GNSS 1 Hz): P stays symmetric
    and positive definite at every epoch (Joseph update, symmetrised predict),
    and the per-kind gate statistics are kept."""
    import pathlib
    import tempfile
    from hyper_nav_filter.core.fusion import FusionEngine
    from hyper_nav_filter.core.measurements import GnssVelocity
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.graph import apply_overrides
    sc = apply_overrides(load_scenario("default"),
                         {"duration_s": DURATION_S, "imu.rate_hz": 10.0, "gnss.rate_hz": 1.0,
                          "start.vel_enu_mps": [1700.0, 0.0, 0.0],
                          "maneuvers": [{"type": "turn", "t_start_s": 600.0 * k + 100.0, "duration_s": 60.0,
                                         "delta": 20.0 * (-1) ** k} for k in range(int(DURATION_S // 600))]},
                         pathlib.Path(tempfile.mkdtemp(prefix="twohours_")))
    traj = sc.trajectory()
    imu, g = simulate.imu_stream(sc, traj), simulate.gnss_stream(sc, traj)
    eng = FusionEngine(sc.filter_config(), sc.filter_initial_state())
    j, worst_asym, min_eig = 0, 0.0, np.inf
    for k in range(len(imu.t_s)):
        eng.add_imu(imu.t_s[k], imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        while j < len(g.t_s) and g.t_s[j] <= imu.t_s[k] + 1e-9:
            eng.add_measurement(GnssPosition(g.t_s[j], g.lat_rad[j], g.lon_rad[j], g.alt_m[j],
                                             np.diag(g.pos_sigma_enu_m**2)))
            eng.add_measurement(GnssVelocity(g.t_s[j], g.vel_enu_mps[j], np.diag(g.vel_sigma_enu_mps**2)))
            j += 1
        for sol in eng.release():
            if k % 20 == 0:
                P = sol.P
                worst_asym = max(worst_asym, np.abs(P - P.T).max())
                min_eig = min(min_eig, np.linalg.eigvalsh(P).min())
    assert worst_asym == 0.0
    assert min_eig > 0.0
    stats = eng.kf.stats
    print(stats, worst_asym, min_eig)
    assert stats["gnss_pos"][0] > 0.97 * DURATION_S and stats["gnss_pos"][1] < 20
    assert 0.5 < stats["gnss_pos"][2] / stats["gnss_pos"][0] < 1.5      # mean NIS per dof ~ 1
