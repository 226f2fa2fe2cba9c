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
from hyper_nav_sim.offline_fly import gnss_measurements

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
