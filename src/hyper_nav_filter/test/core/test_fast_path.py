"""The compiled fast path (core.fast) against the plain numpy reference of
the same filter (``ErrorStateKF(fast=False)``): the same numbers to 1e-9
(relative) in every paper configuration and both frames, through predict,
the lever-arm pre-processing, nominal block propagation and the Joseph
update (issue 15)."""
import dataclasses

import numpy as np
import pytest

from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_sim.core.simulate import gnss_measurements

CASES = [("default", {}), ("default", {"state_blocks": ("att", "vel", "pos", "bg", "ba", "sg", "sa")}),
         ("default", {"mechanization_frame": "LCI"}), ("seed001", {}), ("seed000_elastic", {}),
         ("default", {"state_blocks": ("att", "vel", "pos", "bg", "ba", "clk")}),
         ("seed000_elastic", {"mechanization_frame": "LCI"})]


def fly(sc, cfg, fast, n_epochs):
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    meas = gnss_measurements(sc, traj)
    eng = FusionEngine(cfg, sc.filter_initial_state())
    eng.kf.fast = fast
    j, sols = 0, []
    for k in range(n_epochs):
        eng.add_imu(imu.t_s[k], imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        while j < len(meas) and meas[j].t_s <= imu.t_s[k] + 1e-9:
            eng.add_measurement(meas[j])
            j += 1
        sols += eng.release()
    return sols + eng.release(final=True), eng


@pytest.mark.parametrize("name, extra", CASES)
def test_fast_path_equals_the_numpy_reference(name, extra):
    sc = load_scenario(name)
    cfg = dataclasses.replace(sc.filter_config(), **extra)
    n = int(3.0 * sc["imu.rate_hz"])                 # 3 s: GNSS updates at 10 Hz (seed 001: BDS 1 Hz)
    fast, ef = fly(sc, cfg, True, n)
    ref, er = fly(sc, cfg, False, n)
    assert ef.kf.n_updates == er.kf.n_updates > 0 and len(fast) == len(ref) >= 3.0 * cfg.output_rate_hz
    for a, b in zip(fast, ref):
        np.testing.assert_allclose([a.state.lat_rad, a.state.lon_rad], [b.state.lat_rad, b.state.lon_rad],
                                   rtol=0, atol=1e-13)                    # 1e-13 rad = 0.6 mm
        np.testing.assert_allclose(a.state.alt_m, b.state.alt_m, rtol=1e-9, atol=1e-6)
        np.testing.assert_allclose(a.state.vel_enu_mps, b.state.vel_enu_mps, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(a.state.C_b_n, b.state.C_b_n, rtol=0, atol=1e-12)
        np.testing.assert_allclose(a.P, b.P, rtol=1e-9, atol=1e-9 * np.abs(b.P).max())
        for k in b.state.extra:
            np.testing.assert_allclose(a.state.extra[k], b.state.extra[k], rtol=1e-9, atol=1e-15)


def test_small_inverse_matches_numpy_and_flags_singular():
    from hyper_nav_filter.core.fast.linalg import inv_small
    from hyper_nav_filter.core.fast.update import joseph_update
    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 6, 12):
        A = rng.normal(size=(n, n))
        S = A @ A.T + 1e-3 * np.eye(n)
        ok, Si = inv_small(S)
        assert ok
        np.testing.assert_allclose(Si @ S, np.eye(n), atol=1e-9 * np.linalg.cond(S))
        np.testing.assert_allclose(Si, np.linalg.inv(S), rtol=1e-8, atol=1e-12 * np.abs(Si).max())
    P = np.eye(4)
    ok, _ = inv_small(np.zeros((2, 2)))
    assert not ok
    H = np.zeros((2, 4))                               # H P H^T + R = 0: status 2, P unchanged
    status, nis, dx, P1 = joseph_update(P, H, np.zeros((2, 2)), np.ones(2), 10.0)
    assert status == 2 and np.isinf(nis) and P1 is P


@pytest.mark.parametrize("frame", ["ENU", "LCI"])
@pytest.mark.parametrize("blocks", [("att", "vel", "pos"), ("att", "vel", "pos", "bg", "ba"),
                                    ("att", "vel", "pos", "bg", "gm", "ba", "lev")])
def test_compiled_gnss_models_equal_the_reference(frame, blocks):
    """GnssPosition / GnssVelocity through ``ErrorStateKF.model``: the compiled
    form against the reference models (lever arm, body rate, gyro-bias columns,
    a fix across the 180 deg meridian) to 1e-12."""
    from hyper_nav_filter.core.config import FilterConfig
    from hyper_nav_filter.core.eskf import ErrorStateKF
    from hyper_nav_filter.core.measurements import GnssPosition, GnssVelocity, ModelContext
    from hyper_nav_filter.core.nav_state import ImuSample, NavState
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(11)
    lever_b = np.array([1.2, -0.4, 0.7])
    for lon0 in (0.3, np.pi - 1e-7):
        C = Rotation.from_euler("ZYX", rng.uniform(-1.0, 1.0, 3)).as_matrix()
        nav = NavState(0.0, 0.6, lon0, 30000.0, np.array([1800.0, 300.0, -40.0]), C,
                       gyro_bias_b_radps=np.array([1e-5, -2e-5, 3e-5]))
        cfg = FilterConfig(mechanization_frame=frame, state_blocks=blocks)
        out = {}
        for fast in (True, False):
            kf = ErrorStateKF(cfg, nav)
            kf.fast = fast
            imu = ImuSample(0.02, 0.02, np.array([0.002, -0.001, 0.003]), np.array([0.3, 0.1, 0.2]))
            kf.predict(imu)
            s = kf.state
            fix = GnssPosition(kf.t_s + 0.004, s.lat_rad + 2e-6, s.lon_rad + 3e-6 - (2 * np.pi if lon0 > 3 else 0.0),
                               s.alt_m - 7.0, np.eye(3))
            if lon0 > 3:
                assert fix.lon_rad < -3.0                    # the fix is on the far side of 180 deg
            vel = GnssVelocity(kf.t_s, s.vel_enu_mps + [0.5, -0.2, 0.1], np.eye(3))
            ctx = ModelContext.at(kf, imu, lever_b)
            out[fast] = [kf.model(fix, ctx.shifted(0.004)), kf.model(vel, ctx)]
        for (r1, H1, R1), (r2, H2, R2) in zip(out[True], out[False]):
            np.testing.assert_allclose(r1, r2, rtol=1e-12, atol=1e-9)
            np.testing.assert_allclose(H1, H2, rtol=1e-12, atol=1e-12)
            np.testing.assert_array_equal(R1, R2)
        assert np.abs(out[False][0][0]).max() < 100.0        # metres, not an Earth circumference
        assert np.abs(out[False][1][1][:, :3]).max() > 0.0   # the lever arm reaches the attitude columns


def test_compiled_lci_geodetic_view_equals_numpy():
    """The LCI frame's geodetic/ENU view (lat, lon, alt, vel_enu, C_b_n, C_n_a)
    in compiled form against the numpy form, far from launch (1000 s of Earth
    rotation) and across the 180 deg meridian."""
    from hyper_nav_filter.core.config import FilterConfig
    from hyper_nav_filter.core.frames.lci import LciFrame
    from hyper_nav_filter.core.nav_state import NavState
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(5)
    for lon0 in (0.4, np.pi - 2e-5):
        nav = NavState(100.0, 0.7, lon0, 20000.0, np.array([2500.0, -300.0, 50.0]),
                       Rotation.from_euler("ZYX", [1.0, 0.2, -0.1]).as_matrix())
        frame = LciFrame(FilterConfig(mechanization_frame="LCI"), nav)
        for t_s in (100.0, 350.0, 1100.0):
            x = frame.nominal(nav)
            x[0:3] += rng.normal(0.0, 2e4, 3)                   # tens of km away, both sides of 180 deg
            x[3:6] += rng.normal(0.0, 100.0, 3)
            out = {}
            for fast in (True, False):
                frame.fast, frame._cache_key = fast, None
                out[fast] = frame._geodetic(x.copy(), t_s)
            (a, b) = out[True], out[False]
            np.testing.assert_allclose(a[:2], b[:2], rtol=0, atol=1e-13)          # rad
            np.testing.assert_allclose(a[2], b[2], rtol=0, atol=1e-7)             # m
            for u, v in zip(a[3:], b[3:]):
                np.testing.assert_allclose(u, v, rtol=1e-12, atol=1e-12)
