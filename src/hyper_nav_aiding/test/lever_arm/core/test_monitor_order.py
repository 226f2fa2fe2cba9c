"""The lever-arm node's core (ReestimationMonitor) does not depend on the
arrival order of its topics (issue 22): IMU, GNSS fixes and velocities and
fused states, each stream in its own order but interleaved with random
delays (GNSS up to 1.5 s, less than gnss_hold_s), give the same residual
statistic, the same trigger firings and the same windows, to the bit."""
import random

import numpy as np

from hyper_nav_aiding.lever_arm.core.config import LeverArmLearningConfig
from hyper_nav_aiding.lever_arm.core.monitor import ReestimationMonitor
from hyper_nav_filter.core.fusion import FusionEngine


def _events(doublet):
    """(arrival time, stream, payload): fused states arrive when the engine releases them."""
    sc, cfg, fl = doublet
    eng = FusionEngine(cfg, sc.filter_initial_state())
    imu, ev, j = fl.imu, [], 0
    for k in range(len(imu.t_s)):
        t = float(imu.t_s[k])
        eng.add_imu(t, imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        ev.append((t, "imu", (t, imu.dtheta_b_rad[k], imu.dvel_b_mps[k])))
        while j < len(fl.gnss) and fl.gnss[j].t_s <= t + 1e-9:
            eng.add_measurement(fl.gnss[j])
            ev.append((fl.gnss[j].t_s, "gnss", fl.gnss[j]))
            j += 1
        for s in eng.release():
            st = s.state.copy()
            st.extra = {}
            ev.append((t, "state", (st, s.P)))
    return ev


def _run(cfg, events):
    mon = ReestimationMonitor(cfg)
    windows = []
    for _, kind, x in events:
        w = mon.add_imu(*x) if kind == "imu" else mon.add_gnss(x) if kind == "gnss" else mon.add_state(*x)
        if w is not None:
            windows.append((w.t0_s, w.t_end_s, w.imu_dtheta_b_rad.tobytes(), w.initial_P.tobytes(),
                            tuple(m.t_s for m in w.gnss)))
    return windows, mon


def _shuffled(events, seed):
    rng = random.Random(seed)
    last, out = {}, []
    for k, (t, kind, x) in enumerate(events):
        d = {"imu": 0.0, "gnss": 1.5, "state": 1.0}[kind]
        a = max(t + rng.uniform(0.0, d), last.get(kind, -np.inf))      # each stream in its own order
        last[kind] = a
        out.append((a, k, kind, x))
    return [(a, kind, x) for a, _, kind, x in sorted(out)]


def test_windows_and_triggers_do_not_depend_on_the_arrival_order(doublet):
    cfg = LeverArmLearningConfig.from_block({"window_s": 0.8, "state_period_s": 0.1,
                                             "trigger": {"threshold_m": 0.05, "release_m": 0.02,
                                                         "cooldown_s": 0.5, "averaging_s": 0.2}})
    events = _events(doublet)
    ref, mon = _run(cfg, events)
    assert len(ref) >= 1 and mon.counters["trigger_fired"] >= 1 and mon.counters["not_ready"] > 0
    stat = mon.trigger.statistic_m
    for seed in range(4):
        got, m2 = _run(cfg, _shuffled(events, seed))
        assert got == ref, seed
        assert m2.trigger.statistic_m == stat and dict(m2.counters) == dict(mon.counters)
