"""LCI 15-state error model (seed 001 section 4.1) against the LCI mechanization
itself, and the ECEF GNSS measurement models converted to LCI (section 4.3)."""
import numpy as np
import pytest

from hyper_nav_filter.core import earth
from hyper_nav_filter.core.attitude import attitude_error_n_rad, rotvec_to_C
from hyper_nav_filter.core.lci import error_model as em
from hyper_nav_filter.core.lci import mechanization as mech
from hyper_nav_filter.core.lci.frames import LaunchFrame
from hyper_nav_filter.core.lci.gravity import make_gravity
from hyper_nav_filter.core.nav_state import ImuSample
from hyper_nav_filter.core.state_layout import INS_15 as LAY
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_sim.core.trajectory import Maneuver, Start, Trajectory


def perturbed(truth: mech.LciState, dx) -> mech.LciState:
    """Estimate = truth + error, in the error conventions of error_model."""
    s = truth.copy()
    s.C_b_a = rotvec_to_C(-dx[LAY.sl("att")]) @ truth.C_b_a
    s.v_a_mps = truth.v_a_mps + dx[LAY.sl("vel")]
    s.r_a_m = truth.r_a_m + dx[LAY.sl("pos")]
    s.gyro_bias_b_radps = truth.gyro_bias_b_radps + dx[LAY.sl("bg")]
    s.accel_bias_b_mps2 = truth.accel_bias_b_mps2 + dx[LAY.sl("ba")]
    return s


def error(est: mech.LciState, truth: mech.LciState):
    return np.concatenate([attitude_error_n_rad(est.C_b_a, truth.C_b_a), est.v_a_mps - truth.v_a_mps,
                           est.r_a_m - truth.r_a_m, est.gyro_bias_b_radps - truth.gyro_bias_b_radps,
                           est.accel_bias_b_mps2 - truth.accel_bias_b_mps2])


def vertical_launch():
    start = Start(np.deg2rad(40.0), np.deg2rad(100.0), 100.0, 50.0, np.deg2rad(88.0), np.deg2rad(60.0), 0.0, 0.0)
    return Trajectory(start, [Maneuver("pitch", 2.0, 10.0, np.deg2rad(4.0)), Maneuver("accelerate", 0.0, 40.0, 1200.0),
                              Maneuver("climb", 15.0, 25.0, -np.deg2rad(40.0))], 40.0)


@pytest.mark.parametrize("case", ["cruise_turn", "vertical_launch"])
def test_transition_matrix_matches_mechanization(case):
    """Propagate truth and a perturbed state through the same IMU data for
    2 s: the difference must follow Phi dx0 (cruise: 30 deg turn of the
    default scenario at t = 150 s; vertical launch: through pitch 90 deg)."""
    traj, t0 = (load_scenario("default").trajectory(), 150.0) if case == "cruise_turn" else (vertical_launch(), 6.0)
    tr0 = traj.truth([0.0])
    frame = LaunchFrame(tr0.lat_rad[0], tr0.lon_rad[0], tr0.alt_m[0], np.deg2rad(30.0))
    rate, n = 100.0, 200
    dt = 1.0 / rate
    t = t0 + np.arange(1, n + 1) * dt
    dth, dv = traj.imu_increments(t, dt)
    tr = traj.truth([t0])
    r, v, C = frame.geodetic_to_lci(tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0], tr.vel_enu_mps[0], tr.C_b_n[0], t0)
    truth = mech.LciState(t0, r, v, C)
    dx0 = np.concatenate([np.deg2rad([0.01, -0.01, 0.02]), [0.2, -0.3, 0.1], [3.0, -4.0, 5.0],
                          np.deg2rad([1.0, -1.0, 2.0]) / 3600, [2e-3, -1e-3, 3e-3]])
    est = perturbed(truth, dx0)
    g = make_gravity("j2", frame)
    Qc = np.ones(12)
    Phi_total = np.eye(LAY.dim)
    prev = None
    for k in range(n):
        imu = ImuSample(t[k], dt, dth[k], dv[k])
        F, G = em.system_matrices(truth, dv[k] / dt, dth[k] / dt, frame, LAY)   # random-constant biases
        Phi, _ = em.discretize(F, G, Qc, dt)
        Phi_total = Phi @ Phi_total
        truth = mech.propagate(truth, imu, prev, g)
        est = mech.propagate(est, imu, prev, g)
        prev = imu
    actual = error(est, truth)
    predicted = Phi_total @ dx0
    scale = np.abs(dx0).reshape(5, 3).max(axis=1).repeat(3)
    for name in LAY.names:
        s = LAY.sl(name)
        rel = np.abs(predicted[s] - actual[s]).max() / np.abs(actual[s]).max()
        print(f"\n{case} block {name}: |Phi dx0 - dx| / |dx| = {rel:.2e}", end="")
        np.testing.assert_allclose(predicted[s], actual[s], atol=0.02 * np.abs(actual[s]).max() + 1e-3 * scale[s].max(),
                                   err_msg=f"block {name}")


def _state_and_fix():
    frame = LaunchFrame.from_degrees(34.19785, 108.8284, 365.1, 75.0)
    t = 120.0
    lat, lon, alt = np.deg2rad(35.0), np.deg2rad(110.0), 40e3
    vel_enu = np.array([1500.0, 600.0, 200.0])
    C_b_n = rotvec_to_C(np.array([0.2, -0.4, 1.0]))
    r_a, v_a, C_b_a = frame.geodetic_to_lci(lat, lon, alt, vel_enu, C_b_n, t)
    state = mech.LciState(t, r_a, v_a, C_b_a, np.array([1e-5, -1e-5, 2e-5]), np.zeros(3))
    omega_ib_b = np.array([0.05, -0.2, 0.1])
    lever_b = np.array([1.5, 0.2, -0.3])
    r_e = earth.geodetic_to_ecef(lat, lon, alt)
    v_e = earth.C_n_e(lat, lon) @ vel_enu
    # the antenna's ECEF position and velocity (the body rate w.r.t. ECEF is
    # omega_ib - C_e_b omega_ie; the antenna's inertial velocity is what is modelled)
    C_b_e = earth.C_n_e(lat, lon) @ C_b_n
    r_e_ant = r_e + C_b_e @ lever_b
    w_ie_e = np.array([0.0, 0.0, earth.OMEGA_IE_RADPS])
    v_e_ant = v_e + C_b_e @ np.cross(omega_ib_b, lever_b) - np.cross(w_ie_e, C_b_e @ lever_b)
    return frame, state, omega_ib_b, lever_b, r_e_ant, v_e_ant


def test_gnss_measurements_vanish_at_truth_and_jacobians_match_perturbations():
    frame, state, w_b, l_b, r_e, v_e = _state_and_fix()
    t = state.t_s
    cov = np.diag([4.0, 9.0, 16.0])
    res_p, H_p, R_p = em.gnss_position_ecef(state, LAY, frame, t, r_e, cov, l_b)
    res_v, H_v, R_v = em.gnss_velocity_ecef(state, LAY, frame, t, r_e, v_e, cov * 1e-2, w_b, l_b)
    np.testing.assert_allclose(res_p, 0.0, atol=1e-6)
    np.testing.assert_allclose(res_v, 0.0, atol=1e-9)
    C = frame.C_e_a(t)
    np.testing.assert_allclose(R_p, C @ cov @ C.T, atol=1e-12)
    assert np.trace(R_v) == pytest.approx(np.trace(cov) * 1e-2)
    # H: residual(perturbed) - residual(truth) = H dx for small dx
    rng = np.random.default_rng(5)
    dx = np.concatenate([rng.normal(0, 1e-4, 3), rng.normal(0, 0.1, 3), rng.normal(0, 1.0, 3),
                         rng.normal(0, 1e-5, 3), rng.normal(0, 1e-3, 3)])
    est = perturbed(state, dx)
    # the gyro bias error changes the bias-compensated rate used in the lever-arm term
    w_est = w_b - dx[LAY.sl("bg")]
    rp2, _, _ = em.gnss_position_ecef(est, LAY, frame, t, r_e, cov, l_b)
    rv2, _, _ = em.gnss_velocity_ecef(est, LAY, frame, t, r_e, v_e, cov, w_est, l_b)
    np.testing.assert_allclose(rp2 - res_p, H_p @ dx, atol=1e-6)
    np.testing.assert_allclose(rv2 - res_v, H_v @ dx, atol=1e-8)


def test_inject_undoes_a_known_error():
    frame, state, *_ = _state_and_fix()
    dx = np.concatenate([[1e-3, -2e-3, 5e-4], [0.3, -0.2, 0.1], [5.0, -3.0, 2.0], [1e-5, 2e-5, -1e-5], [1e-3, 0, 2e-3]])
    est = perturbed(state, dx)
    fixed = em.inject(est, dx)
    np.testing.assert_allclose(error(fixed, state), 0.0, atol=1e-9)
