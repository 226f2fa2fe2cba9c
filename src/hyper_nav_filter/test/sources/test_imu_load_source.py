"""The IMU source's structure-load input (``load_topic``, seed 000 eq. 22's
known input u_q): the live path (sensor_msgs/Imu messages on imu/data_raw and
imu/load through the router, in either arrival order) gives the filter the
same samples as the offline core fed ``add_imu(..., load_f_b_mps2)``, and the
load changes the solution (the node uses it). Duck-typed messages."""
from types import SimpleNamespace as NS

import numpy as np
import pytest

from hyper_nav_filter.conversions import stamp_to_s
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_filter.sources.router import SourceRouter

DT, N_SUB, N = 0.02, 8, 100
CFG = FilterConfig(state_blocks=("att", "vel", "pos", "bg", "gm", "ba", "lev"), output_rate_hz=10.0)


def header(t):
    ns = int(round(t * 1e9))
    return NS(stamp=NS(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="imu_link")


def imu_msg(t, w, f):
    return NS(header=header(t), angular_velocity=NS(x=w[0], y=w[1], z=w[2]),
              linear_acceleration=NS(x=f[0], y=f[1], z=f[2]))


def engine():
    return FusionEngine(CFG, NavState(0.0, 0.5, 2.0, 25000.0, np.zeros(3), np.eye(3)))


def flight():
    """A level 2 s record: IMU samples (t, w, f) at 50 Hz and, per interval,
    the load sensor's 8 sub-interval means (a 15 rad/s normal-load wobble of
    2 m/s^2 on 1 g): the messages' float64 values, so both paths see the same numbers."""
    rng = np.random.default_rng(3)
    t = np.array([stamp_to_s(header(x).stamp) for x in DT * np.arange(1, N + 1)])     # as the stamps say
    t_sub = (t[:, None] - DT + DT / N_SUB * np.arange(1, N_SUB + 1))
    t_sub[:, -1] = t
    load = np.zeros((N, N_SUB, 3))
    load[..., 2] = 9.78 + 2.0 * np.sin(15.0 * t_sub)
    w = 1e-5 * rng.standard_normal((N, 3))
    f = np.column_stack([np.zeros(N), np.zeros(N), 9.78 + 0.01 * rng.standard_normal(N)])
    return t, w, f, t_sub, load


def live(order: str):
    t, w, f, t_sub, load = flight()
    router = SourceRouter(engine(), {"imu": {"type": "imu", "topic": "imu/data_raw", "load_topic": "imu/load"}})
    assert set(router.topics()) == {"imu/data_raw", "imu/load"}
    sols = []
    for k in range(N):
        loads = [("imu/load", imu_msg(ts, np.zeros(3), fs)) for ts, fs in zip(t_sub[k], load[k])]
        main = [("imu/data_raw", imu_msg(t[k], w[k], f[k]))]
        msgs = loads + main if order == "load first" else main + loads
        for topic, m in msgs:
            reason, s = router.handle_topic(topic, m)
            assert reason is None
            sols += s
    sols += router.engine.release(final=True)
    return router, sols


def offline(with_load: bool):
    t, w, f, _, load = flight()
    eng, t_prev, sols = engine(), 0.0, []
    for k in range(N):
        dt = t[k] - t_prev
        ok, _ = eng.add_imu(t[k], w[k] * dt, f[k] * dt, load[k] if with_load else None)
        assert ok
        t_prev = t[k]
        sols += eng.release()
    return sols + eng.release(final=True)


@pytest.mark.parametrize("order", ["load first", "imu first"])
def test_live_load_input_gives_the_offline_solution(order):
    router, sols = live(order)
    ref, without = offline(True), offline(False)
    assert len(sols) == len(ref) == len(without) >= 19
    for a, b in zip(sols, ref):
        assert a.t_s == b.t_s
        np.testing.assert_allclose(a.state.vel_enu_mps, b.state.vel_enu_mps, rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(a.state.extra["lev"], b.state.extra["lev"], rtol=0.0, atol=1e-15)
    # the load is used: without it the measured 1 g force stands in and the modes do not wobble
    lev_load = np.array([s.state.extra["lev"] for s in ref])
    lev_none = np.array([s.state.extra["lev"] for s in without])
    assert np.max(np.abs(lev_load[:, :3] - lev_none[:, :3])) > 1e-3      # m (static deflection 2/15^2 ... per mode)
    d = router.diagnostics()
    assert d["received imu/load"] == N * N_SUB and d["received imu/data_raw"] == N
    assert "processed imu/data_raw (without load)" not in d and d["held imu waiting for load"] == 0


def test_a_stopped_load_stream_releases_the_held_samples_without_load():
    t, w, f, t_sub, load = flight()
    router = SourceRouter(engine(), {"imu": {"type": "imu", "topic": "imu/data_raw", "load_topic": "imu/load",
                                             "load_max_held": 5}})
    for k in range(20):
        router.handle_topic("imu/data_raw", imu_msg(t[k], w[k], f[k]))
    assert router.engine.counters["imu_accepted"] == 15          # 5 held, the oldest 15 went without
    d = router.diagnostics()
    assert d["processed imu/data_raw (without load)"] == 15 and d["held imu waiting for load"] == 5
