"""ESKF: the update against the closed-form Kalman solution, configuration
errors, covariance health over two hours, and time-stamped model updates.
(The linearized error model against the mechanization, every block and both
frames: test_frames_and_blocks.)"""
import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_filter.core.config import ConfigError, FilterConfig
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.measurements import GnssPosition, ModelContext
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_sim.core.scenario import load_scenario

CFG = FilterConfig()
DURATION_S = 7200.0
LAY = CFG.layout


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
    with pytest.raises(ConfigError, match="gyro_bias_tau_s.*did you mean 'gyro_bias_tau_s'"):
        FilterConfig.from_dict({"gyro_bias_tau_ss": 3600.0})
    with pytest.raises(ConfigError, match="state_blocks.*start with"):
        FilterConfig(state_blocks=("vel", "att", "pos"))
    # an integer where a float is declared is coerced (scenario files write 3600)
    cfg = FilterConfig.from_dict({"gyro_bias_tau_s": 3600, "init_pos_sigma_m": [5, 5, 10]})
    assert isinstance(cfg.gyro_bias_tau_s, float) and cfg.init_pos_sigma_m == (5.0, 5.0, 10.0)
    with pytest.raises(ConfigError, match="not an updatable"):
        cfg.with_updates({"gyro_bias_tau_s": 10.0})
    upd = cfg.with_updates({"lever_arm_natural_freq_radps": [20.0, 55.0, 113.0]})
    assert upd.lever_arm_natural_freq_radps == (20.0, 55.0, 113.0) and upd.gyro_bias_tau_s == 3600.0


@pytest.mark.slow
def test_covariance_stays_symmetric_positive_definite_over_two_hours():
    """A 2-hour hypersonic cruise (10 Hz IMU, GNSS 1 Hz): P stays symmetric
    and positive definite at every epoch (Joseph update, symmetrised predict),
    and the per-kind gate statistics are kept."""
    import pathlib
    import tempfile
    from hyper_nav_filter.core.fusion import FusionEngine
    from hyper_nav_filter.core.measurements import GnssVelocity
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.core.scenario import apply_overrides
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
