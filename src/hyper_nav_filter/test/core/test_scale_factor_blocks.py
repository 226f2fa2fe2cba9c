"""Scale-factor state blocks ``sg`` / ``sa`` (core.state_layout): the
linearized error models (ENU core.error_model, LCI core.lci.error_model)
against the mechanizations themselves, and the exact compensation
omega = (omega_meas - b) / (1 + s)."""
import numpy as np
import pytest

from hyper_nav_filter.core.attitude import attitude_error_n_rad
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.error_model import discretize, system_matrices
from hyper_nav_filter.core.lci import error_model as lci_em
from hyper_nav_filter.core.lci import mechanization as lci_mech
from hyper_nav_filter.core.lci.frames import LaunchFrame
from hyper_nav_filter.core.lci.gravity import make_gravity
from hyper_nav_filter.core.nav_state import ImuSample, NavState
from hyper_nav_filter.core.state_layout import INS_21_SF as LAY
from hyper_nav_sim.core.scenario import load_scenario

SG = np.array([800e-6, -600e-6, 1000e-6])
SA = np.array([-700e-6, 900e-6, 500e-6])


def _turn(n=200, rate=100.0, t0=150.0):
    """2 s of the default scenario's 30-degree hypersonic turn."""
    traj = load_scenario("default").trajectory()
    dt = 1.0 / rate
    t = t0 + np.arange(1, n + 1) * dt
    dth, dv = traj.imu_increments(t, dt)
    return traj, t0, t, dt, dth, dv


def test_compensation_divides_out_the_scale_factor():
    nav = NavState(0.0, 0.5, 1.0, 100.0, np.zeros(3), np.eye(3), np.full(3, 1e-5), np.full(3, 1e-3),
                   {"sg": SG.copy(), "sa": SA.copy()})
    w, f, dt = np.array([0.1, -0.2, 0.3]), np.array([20.0, -3.0, 9.0]), 0.01
    dth, dv = nav.compensate(((1 + SG) * w + 1e-5) * dt, ((1 + SA) * f + 1e-3) * dt, dt)
    np.testing.assert_allclose(dth, w * dt, rtol=1e-12)
    np.testing.assert_allclose(dv, f * dt, rtol=1e-12)


def _dx0():
    dx0 = np.zeros(LAY.dim)
    dx0[LAY.sl("sg")] = SG
    dx0[LAY.sl("sa")] = SA
    return dx0


def _check(predicted, actual, label):
    for name in ("att", "vel", "pos"):
        s = LAY.sl(name)
        rel = np.abs(predicted[s] - actual[s]).max() / np.abs(actual[s]).max()
        print(f"\n{label} block {name}: |Phi dx0 - dx| / |dx| = {rel:.2e} (|dx| {np.abs(actual[s]).max():.2e})", end="")
        assert rel < 0.02, (name, predicted[s], actual[s])


def test_enu_transition_matrix_matches_mechanization_for_scale_factors():
    """Estimate carries scale factors SG/SA the truth does not have (error =
    estimate - truth): after 2 s of the turn the att/vel/pos errors follow Phi dx0."""
    cfg = FilterConfig(state_blocks=LAY.names)
    traj, t0, t, dt, dth, dv = _turn()
    tr = traj.truth([t0])
    truth = NavState(t0, tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0], tr.vel_enu_mps[0], tr.C_b_n[0],
                     extra={"sg": np.zeros(3), "sa": np.zeros(3)})
    est = truth.copy()
    est.extra = {"sg": SG.copy(), "sa": SA.copy()}
    kf_t = ErrorStateKF(cfg, truth, np.eye(LAY.dim))
    kf_e = ErrorStateKF(cfg, est, np.eye(LAY.dim))
    Phi_total = np.eye(LAY.dim)
    for k in range(len(t)):
        F, G, Qc = system_matrices(kf_t.state, dv[k] / dt, dth[k] / dt, LAY, cfg)
        Phi_total = discretize(F, G, Qc, dt)[0] @ Phi_total
        imu = ImuSample(t[k], dt, dth[k], dv[k])
        kf_t.predict(imu)
        kf_e.predict(imu)
    from hyper_nav_filter.core import earth
    e, tr_ = kf_e.state, kf_t.state
    actual = np.zeros(LAY.dim)
    actual[LAY.sl("att")] = attitude_error_n_rad(e.C_b_n, tr_.C_b_n)
    actual[LAY.sl("vel")] = e.vel_enu_mps - tr_.vel_enu_mps
    actual[LAY.sl("pos")] = earth.position_error_enu_m(e.lat_rad, e.lon_rad, e.alt_m, tr_.lat_rad, tr_.lon_rad,
                                                       tr_.alt_m)
    _check(Phi_total @ _dx0(), actual, "ENU")


def test_lci_transition_matrix_matches_mechanization_for_scale_factors():
    traj, t0, t, dt, dth, dv = _turn()
    tr0 = traj.truth([0.0])
    frame = LaunchFrame(tr0.lat_rad[0], tr0.lon_rad[0], tr0.alt_m[0], np.deg2rad(30.0))
    tr = traj.truth([t0])
    r, v, C = frame.geodetic_to_lci(tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0], tr.vel_enu_mps[0], tr.C_b_n[0], t0)
    truth = lci_mech.LciState(t0, r, v, C)
    est = truth.copy()
    est.extra = {"sg": SG.copy(), "sa": SA.copy()}
    g = make_gravity("j2", frame)
    Phi_total, prev = np.eye(LAY.dim), None
    for k in range(len(t)):
        F, G = lci_em.system_matrices(truth, dv[k] / dt, dth[k] / dt, frame, LAY)
        Phi_total = lci_em.discretize(F, G, np.ones(12), dt)[0] @ Phi_total
        imu = ImuSample(t[k], dt, dth[k], dv[k])
        truth = lci_mech.propagate(truth, imu, prev, g)
        est = lci_mech.propagate(est, imu, prev, g)
        prev = imu
    actual = np.zeros(LAY.dim)
    actual[LAY.sl("att")] = attitude_error_n_rad(est.C_b_a, truth.C_b_a)
    actual[LAY.sl("vel")] = est.v_a_mps - truth.v_a_mps
    actual[LAY.sl("pos")] = est.r_a_m - truth.r_a_m
    _check(Phi_total @ _dx0(), actual, "LCI")


def test_inject_corrects_the_scale_factors():
    est = lci_mech.LciState(0.0, np.zeros(3), np.zeros(3), np.eye(3), extra={"sg": SG.copy(), "sa": SA.copy()})
    dx = _dx0()
    out = lci_em.inject(est, dx, LAY)
    np.testing.assert_allclose(out.extra["sg"], 0.0, atol=1e-18)
    np.testing.assert_allclose(out.extra["sa"], 0.0, atol=1e-18)
    cfg = FilterConfig(state_blocks=LAY.names)
    assert cfg.initial_covariance()[LAY.sl("sg"), LAY.sl("sg")][0, 0] == pytest.approx((100e-6) ** 2)
