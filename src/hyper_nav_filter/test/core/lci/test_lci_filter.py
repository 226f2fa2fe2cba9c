"""LCI error-state filter (core.lci.filter.LciErrorStateKF) through the
FusionEngine: seed 001 boost-glide accuracy, vertical flight, and agreement
with the ENU filter on the default scenario.

The seed 001 IMU (500 Hz) is fed at 100 Hz: five consecutive increments are
summed (exactly the integral over the 10 ms interval; only the coning /
sculling resolution changes), which keeps a 600 s run ~1 min.
"""
import dataclasses
import functools
import time

import numpy as np
import pytest

from hyper_nav_filter.core import earth
from hyper_nav_filter.core.attitude import attitude_error_n_rad, rotvec_to_C
from hyper_nav_filter.core.config import ConfigError, FilterConfig
from hyper_nav_filter.core.fusion import MODE_LOOSELY_COUPLED, FusionEngine, make_filter
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.lci.filter import LciErrorStateKF, UnsupportedMeasurement
from hyper_nav_filter.core.measurements import BaroHeight, GnssPosition, GnssVelocity, ModelContext
from hyper_nav_filter.core.nav_state import ImuSample, NavState
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.imu_model import ImuErrors
from hyper_nav_sim.core.scenario import load_scenario

SEED001_AZIMUTH_DEG = 90.0       # flight.start.psi_deg of seed001.yaml
CONVERGED_S = 100.0              # accuracy window starts here
BIAS_FROM_S = 200.0              # bias-estimate window starts here


def _measurements(sc, traj):
    g = simulate.gnss_stream(sc, traj)
    meas = []
    for i in range(len(g.t_s)):
        meas.append(GnssVelocity(g.t_s[i], g.vel_enu_mps[i], np.diag(g.vel_sigma_enu_mps**2)))
        meas.append(GnssPosition(g.t_s[i], g.lat_rad[i], g.lon_rad[i], g.alt_m[i], np.diag(g.pos_sigma_enu_m**2)))
    meas.sort(key=lambda m: (m.t_s, m.kind))
    return meas


def fly(sc, cfg, decimate=1, duration_s=None):
    """Run the engine over the scenario; returns (solutions, engine, traj, seconds)."""
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    n = len(imu.t_s) if duration_s is None else int(round(duration_s / imu.dt_s))
    n -= n % decimate
    t = imu.t_s[decimate - 1:n:decimate]
    dth = imu.dtheta_b_rad[:n].reshape(-1, decimate, 3).sum(axis=1)
    dv = imu.dvel_b_mps[:n].reshape(-1, decimate, 3).sum(axis=1)
    meas = _measurements(sc, traj)
    eng = FusionEngine(cfg, sc.filter_initial_state())
    sols, j = [], 0
    t0 = time.perf_counter()
    for k in range(len(t)):
        eng.add_imu(t[k], dth[k], dv[k])
        while j < len(meas) and meas[j].t_s <= t[k] + 1e-9:
            eng.add_measurement(meas[j])
            j += 1
        if k % 10 == 9:
            sols += eng.release()
    sols += eng.release(final=True)
    return sols, eng, traj, time.perf_counter() - t0


def per_axis_errors(sols, traj, t_from):
    """ENU per-axis errors of the released solutions from t_from on:
    dict name -> (N, 3) array (att deg, vel m/s, pos m) and the times."""
    sols = [s for s in sols if s.t_s >= t_from - 1e-9]
    t = np.array([s.t_s for s in sols])
    tr = traj.truth(t)
    pos = np.array([earth.position_error_enu_m(s.state.lat_rad, s.state.lon_rad, s.state.alt_m,
                                               tr.lat_rad[i], tr.lon_rad[i], tr.alt_m[i]) for i, s in enumerate(sols)])
    vel = np.array([s.state.vel_enu_mps for s in sols]) - tr.vel_enu_mps
    att = np.rad2deg([attitude_error_n_rad(s.state.C_b_n, tr.C_b_n[i]) for i, s in enumerate(sols)])
    return t, {"att": att, "vel": vel, "pos": pos}


def summarize(err):
    return {k: (np.sqrt(np.mean(e**2, axis=0)), np.max(np.abs(e), axis=0)) for k, e in err.items()}


def lci_config(sc, **kw):
    return dataclasses.replace(sc.filter_config(), mechanization_frame="LCI",
                               launch_azimuth_deg=SEED001_AZIMUTH_DEG, **kw)


@functools.lru_cache(maxsize=None)
def seed001_run(scale_factors: bool):
    sc = load_scenario("seed001")
    if not scale_factors:
        sc.data["imu"]["gyro_scale_factor_ppm"] = 0.0
        sc.data["imu"]["accel_scale_factor_ppm"] = 0.0
    sols, eng, traj, secs = fly(sc, lci_config(sc), decimate=5)
    truth = ImuErrors.from_scenario(sc)
    return sols, eng, traj, secs, truth


def _report(label, sols, eng, traj, secs, truth):
    _, err = per_axis_errors(sols, traj, CONVERGED_S)
    s = summarize(err)
    last = sols[-1].state
    bg_est, ba_est = last.gyro_bias_b_radps, last.accel_bias_b_mps2
    print(f"\n[{label}] run {secs:.1f} s, {eng.kf.n_updates} updates, {eng.kf.n_rejected} rejected")
    for k, unit in (("att", "deg"), ("vel", "m/s"), ("pos", "m")):
        print(f"  {k} t>={CONVERGED_S:.0f}s RMS ENU {np.round(s[k][0], 4)} max {np.round(s[k][1], 4)} {unit}")
    print(f"  gyro bias est {np.round(np.rad2deg(bg_est) * 3600, 3)} truth "
          f"{np.round(np.rad2deg(truth.gyro_bias_b_radps) * 3600, 3)} deg/h")
    print(f"  accel bias est {np.round(ba_est / 9.80665e-6, 1)} truth {np.round(truth.accel_bias_b_mps2 / 9.80665e-6, 1)} ug")
    return s


def _bias_rel_errors(sols, truth):
    """Max over t >= BIAS_FROM_S of the relative bias errors per axis."""
    late = [x for x in sols if x.t_s >= BIAS_FROM_S]
    bg = np.array([x.state.gyro_bias_b_radps for x in late])
    ba = np.array([x.state.accel_bias_b_mps2 for x in late])
    rg = np.max(np.abs(bg - truth.gyro_bias_b_radps) / np.abs(truth.gyro_bias_b_radps), axis=0)
    ra = np.max(np.abs(ba - truth.accel_bias_b_mps2) / np.abs(truth.accel_bias_b_mps2), axis=0)
    print(f"  max rel bias error t>={BIAS_FROM_S:.0f}s gyro {np.round(rg, 3)} accel {np.round(ra, 3)}")
    return rg, ra


def test_seed001_lci_accuracy_after_convergence():
    """Seed 001 from t >= 100 s, per ENU axis RMS, with the scenario's
    100 ppm scale-factor errors (not in the 15-state model).
    Issue: velocity < 0.2 m/s, position < 10 m -> met (measured RMS
    <= 0.08 m/s, <= 1.7 m). Attitude < 0.05 deg -> NOT met: measured RMS
    (0.095, 0.068, 0.160) deg E/N/U, and the ENU filter gives the same
    (0.094, 0.068, 0.164) on the same data, so it is the observability of
    this flight (heading in the low-acceleration glide, gyro ARW
    0.3 deg/sqrt(h)), not the LCI mechanization. Asserted: 0.2 deg RMS."""
    sols, eng, traj, secs, truth = seed001_run(True)
    s = _report("seed001 LCI, 100 ppm scale factors", sols, eng, traj, secs, truth)
    _bias_rel_errors(sols, truth)
    assert sols[-1].t_s == pytest.approx(600.0)
    assert sols[-1].mode == MODE_LOOSELY_COUPLED
    assert eng.kf.n_rejected == 0
    assert np.all(s["vel"][0] < 0.2), s["vel"]
    assert np.all(s["pos"][0] < 10.0), s["pos"]
    assert np.all(s["att"][0] < 0.2), s["att"]
    assert np.all(np.linalg.eigvalsh(sols[-1].P) > 0)


def test_seed001_lci_bias_estimates_without_scale_factor_errors():
    """Scale factors set to 0: the same accuracy (so the scale factors are
    not what limits it) and the final bias estimates within 30 % of the
    truth (measured: gyro 2.68/-2.74/3.82 deg/h vs 3/-3/3, i.e. 11/9/27 %;
    accel 912/-965/923 ug vs 1000/-1000/1000, i.e. 9/4/8 %)."""
    sols, eng, traj, secs, truth = seed001_run(False)
    s = _report("seed001 LCI, scale factors 0", sols, eng, traj, secs, truth)
    _bias_rel_errors(sols, truth)
    assert np.all(s["vel"][0] < 0.2) and np.all(s["pos"][0] < 10.0) and np.all(s["att"][0] < 0.2), s
    last = sols[-1].state
    rg = np.abs(last.gyro_bias_b_radps - truth.gyro_bias_b_radps) / np.abs(truth.gyro_bias_b_radps)
    ra = np.abs(last.accel_bias_b_mps2 - truth.accel_bias_b_mps2) / np.abs(truth.accel_bias_b_mps2)
    assert np.all(rg < 0.3) and np.all(ra < 0.3), (rg, ra)


@pytest.mark.xfail(strict=True, reason="issue requirement not met by the 15-state filter on this flight "
                   "(ENU filter alike): attitude RMS 0.07-0.16 deg > 0.05, gyro bias z 27 % off at 600 s")
def test_seed001_issue_requirements_strict():
    """The issue's figures as stated: attitude < 0.05 deg RMS per axis
    (t >= 100 s) and every bias estimate within 10 % for all t >= 200 s."""
    sols, eng, traj, secs, truth = seed001_run(False)
    _, err = per_axis_errors(sols, traj, CONVERGED_S)
    rg, ra = _bias_rel_errors(sols, truth)
    assert np.all(summarize(err)["att"][0] < 0.05)
    assert np.all(rg < 0.1) and np.all(ra < 0.1)


def test_vertical_flight_no_nan_and_rejects_unknown_measurements():
    """Pitch 90 deg (nose up, seed 001's first 4 s) and through it: the LCI
    filter stays finite (no Euler angles anywhere in it)."""
    sc = load_scenario("seed001")
    cfg = lci_config(sc)
    tr = sc.trajectory().truth([0.0, 2.0, 6.0])
    C = tr.C_b_n[0]
    assert C[2, 0] == pytest.approx(1.0, abs=1e-6)      # body x along up: pitch 90 deg
    sols, eng, traj, _ = fly(sc, cfg, decimate=5, duration_s=20.0)
    for s in sols:
        assert np.all(np.isfinite(s.state.C_b_n)) and np.all(np.isfinite(s.state.vel_enu_mps))
        assert np.isfinite(s.state.lat_rad) and np.all(np.isfinite(s.P))
    _, err = per_axis_errors(sols, traj, 0.0)
    assert np.max(np.abs(err["att"])) < 0.2 and np.max(np.abs(err["pos"])) < 30.0
    with pytest.raises(UnsupportedMeasurement, match="baro"):
        eng.kf.model(BaroHeight(1.0, 100.0, 1.0), ModelContext(np.zeros(3), np.zeros(3), 0.0))


def test_lci_matches_enu_filter_on_default_scenario():
    """Same inputs through the ENU and the LCI filter: the ENU outputs agree
    to the mechanization difference over the first 120 s (measured max:
    7 mm, 1.3 mm/s, 0.0007 deg; bounds 0.5 m, 0.01 m/s, 0.005 deg)."""
    sc = load_scenario("default")
    out = {}
    for frame in ("ENU", "LCI"):
        cfg = dataclasses.replace(sc.filter_config(), mechanization_frame=frame)
        sols, eng, traj, _ = fly(sc, cfg, duration_s=120.0)
        out[frame] = sols
        assert isinstance(eng.kf, LciErrorStateKF if frame == "LCI" else ErrorStateKF)
    a, b = out["ENU"], out["LCI"]
    assert len(a) == len(b) and [x.t_s for x in a] == [x.t_s for x in b]
    dpos = np.array([earth.position_error_enu_m(x.state.lat_rad, x.state.lon_rad, x.state.alt_m,
                                                y.state.lat_rad, y.state.lon_rad, y.state.alt_m) for x, y in zip(a, b)])
    dvel = np.array([x.state.vel_enu_mps - y.state.vel_enu_mps for x, y in zip(a, b)])
    datt = np.rad2deg([attitude_error_n_rad(x.state.C_b_n, y.state.C_b_n) for x, y in zip(a, b)])
    print(f"\n[ENU vs LCI, default] max |dpos| {np.abs(dpos).max(0)} m, |dvel| {np.abs(dvel).max(0)} m/s, "
          f"|datt| {np.abs(datt).max(0)} deg")
    assert np.abs(dpos).max() < 0.5
    assert np.abs(dvel).max() < 0.01
    assert np.abs(datt).max() < 0.005
    # the ENU view of the covariance agrees as well (position block, sigma within 10 %)
    sa = np.sqrt(np.diag(a[-1].P)[6:9])
    sb = np.sqrt(np.diag(b[-1].P)[6:9])
    np.testing.assert_allclose(sb, sa, rtol=0.1)


def test_snapshot_restore_and_late_measurements_are_exact():
    """Re-processing (GNSS delivered 200 ms late) gives the same LCI solutions
    as on-time delivery: snapshot/restore round-trips the filter."""
    sc = load_scenario("default")
    cfg = dataclasses.replace(sc.filter_config(), mechanization_frame="LCI")
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    meas = _measurements(sc, traj)
    res = []
    for delay in (0.0, 0.2):
        eng = FusionEngine(cfg, sc.filter_initial_state())
        sols, j = [], 0
        for k in range(int(20 * sc["imu.rate_hz"])):
            eng.add_imu(imu.t_s[k], imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
            while j < len(meas) and meas[j].t_s + delay <= imu.t_s[k] + 1e-9:
                eng.add_measurement(meas[j])
                j += 1
            sols += eng.release()
        res.append((sols, eng))
    (a, _), (b, eng) = res
    assert eng.counters["gnss_pos_late"] > 15
    assert len(a) == len(b) > 900
    for x, y in zip(a, b):
        np.testing.assert_allclose([x.state.lat_rad, x.state.lon_rad, x.state.alt_m],
                                   [y.state.lat_rad, y.state.lon_rad, y.state.alt_m], rtol=0, atol=1e-12)
        np.testing.assert_allclose(x.state.vel_enu_mps, y.state.vel_enu_mps, rtol=0, atol=1e-9)
        np.testing.assert_allclose(x.P, y.P, rtol=1e-9, atol=1e-18)


def test_config_and_make_filter():
    assert FilterConfig().mechanization_frame == "ENU"
    with pytest.raises(ConfigError, match="mechanization_frame"):
        FilterConfig(mechanization_frame="NED")
    with pytest.raises(ConfigError, match="lci_gravity"):
        FilterConfig(lci_gravity="egm")
    with pytest.raises(ConfigError, match="launch_azimuth_deg"):
        FilterConfig(launch_azimuth_deg=float("nan"))
    cfg = FilterConfig.from_dict({"mechanization_frame": "LCI", "launch_azimuth_deg": 45.0})
    init = NavState(0.0, np.deg2rad(34.0), np.deg2rad(108.0), 500.0, np.array([0.0, 0.0, 10.0]),
                    rotvec_to_C(np.array([0.0, -np.pi / 2, 0.0])))
    kf = make_filter(cfg, init)
    assert isinstance(kf, LciErrorStateKF)
    # the ENU view of the initial state is the given one; P0 round-trips through LCI
    assert kf.state.lat_rad == pytest.approx(init.lat_rad, abs=1e-12)
    assert kf.state.alt_m == pytest.approx(500.0, abs=1e-6)
    np.testing.assert_allclose(kf.state.vel_enu_mps, init.vel_enu_mps, atol=1e-9)
    np.testing.assert_allclose(kf.state.C_b_n, init.C_b_n, atol=1e-12)
    np.testing.assert_allclose(kf.P_enu(), cfg.initial_covariance(), atol=1e-12)
    with pytest.raises(ConfigError, match="state_blocks"):
        make_filter(FilterConfig(mechanization_frame="LCI", state_blocks=("att", "vel", "pos", "bg", "ba", "clk")),
                    init)
    # one predict step from rest is finite
    kf.predict(ImuSample(0.01, 0.01, np.zeros(3), np.array([9.8, 0.0, 0.0]) * 0.01))
    assert np.all(np.isfinite(kf.P)) and np.isfinite(kf.state.alt_m)
