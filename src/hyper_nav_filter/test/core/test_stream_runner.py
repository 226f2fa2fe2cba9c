"""The one engine-over-streams loop (hyper_nav_filter.core.stream_runner):
its order of calls per IMU sample, the receiver-latency feed, and on a real
flight the same solutions bit for bit as the hand-written loop it replaced
(offline_fly.fly before issue 34), whatever the release cadence."""
import numpy as np
import pytest

from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.stream_runner import Stamped, StreamRunner


class _Log:
    """An engine that logs its calls; it releases one marker per release."""

    def __init__(self):
        self.calls = []

    def add_imu(self, t, dth, dv):
        self.calls.append(("imu", t))

    def add_measurement(self, m):
        self.calls.append(("meas", m.t_s))

    def release(self, final=False):
        self.calls.append(("release", final))
        return [("sol", len(self.calls))]


class _M:
    def __init__(self, t_s):
        self.t_s = t_s


class _Aiding:
    def __init__(self):
        self.got = []

    def released(self, eng, sols):
        self.got.append(list(sols))


def test_order_per_sample_and_the_release_cadence():
    eng, aid = _Log(), _Aiding()
    t = np.array([0.1, 0.2, 0.3, 0.4])
    z = np.zeros((4, 3))
    sols = StreamRunner(eng, [Stamped([_M(0.2), _M(0.25), _M(0.4)]), aid], release_every=2).run(t, z, z)
    assert eng.calls == [("imu", 0.1), ("imu", 0.2), ("meas", 0.2), ("release", False),
                         ("imu", 0.3), ("meas", 0.25), ("imu", 0.4), ("meas", 0.4), ("release", False),
                         ("release", True)]
    assert sols == [("sol", 4), ("sol", 9), ("sol", 10)]
    assert aid.got == [[("sol", 4)], [("sol", 9)], [("sol", 10)]]        # every release, the final one too


def test_a_receiver_latency_puts_the_fix_before_the_first_later_sample():
    eng = _Log()
    t = np.array([0.1, 0.2, 0.3, 0.4])
    z = np.zeros((4, 3))
    run = StreamRunner(eng, [Stamped([_M(0.1), _M(0.2)], delivery_delay_s=0.15)], keep=lambda s: False)
    wall = np.full(4, -1.0)
    seen = []
    assert run.run(t, z, z, n=3, on_sample=lambda k, tk: seen.append((k, tk)), imu_wall_s=wall) == []
    # 0.1 + 0.15 = 0.25 < 0.3: before the 0.3 sample; 0.2 + 0.15 = 0.35: after the last sample taken (n=3)
    assert [c for c in eng.calls if c[0] != "release"] == [("imu", 0.1), ("imu", 0.2), ("meas", 0.1), ("imu", 0.3)]
    assert seen == [(0, 0.1), (1, 0.2), (2, 0.3)]
    assert (wall[:3] >= 0.0).all() and wall[3] == -1.0
    with pytest.raises(ValueError, match="release_every"):
        StreamRunner(eng, release_every=0)


def _hand_written_loop(sc, cfg, meas, imu, n, release_every):
    """offline_fly.fly's loop as it was before the runner (9bcca3c)."""
    eng = FusionEngine(cfg, sc.filter_initial_state())
    sols, j = [], 0
    for k in range(n):
        eng.add_imu(imu.t_s[k], imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        while j < len(meas) and meas[j].t_s <= imu.t_s[k] + 1e-9:
            eng.add_measurement(meas[j])
            j += 1
        if k % release_every == release_every - 1:
            sols += eng.release()
    return sols + eng.release(final=True)


def test_a_flight_through_the_runner_equals_the_hand_written_loop_bit_for_bit():
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.core.scenario import load_scenario
    sc = load_scenario("default")
    cfg = sc.filter_config()
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    meas = simulate.gnss_measurements(sc, traj)
    n = int(round(20.0 / imu.dt_s))
    ref = _hand_written_loop(sc, cfg, meas, imu, n, 10)
    for every in (1, 10, 37):
        sols = StreamRunner(FusionEngine(cfg, sc.filter_initial_state()), [Stamped(meas)], every).run(
            imu.t_s, imu.dtheta_b_rad, imu.dvel_b_mps, n)
        assert len(sols) == len(ref) > 100
        assert all(a.t_s == b.t_s and (a.state.lat_rad, a.state.lon_rad, a.state.alt_m)
                   == (b.state.lat_rad, b.state.lon_rad, b.state.alt_m)
                   and np.array_equal(a.state.vel_enu_mps, b.state.vel_enu_mps)
                   and np.array_equal(a.state.C_b_n, b.state.C_b_n) and np.array_equal(a.P, b.P)
                   for a, b in zip(sols, ref)), every
