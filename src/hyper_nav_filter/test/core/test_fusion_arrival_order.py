"""The fusion engine under any arrival order (issue 22), property-based.

For random arrival orders of IMU samples, loosely coupled GNSS (position,
velocity), aiding fixes (horizontal fix, barometric height), model updates
and tightly coupled pseudoranges, with messages ahead of their IMU epoch and
up to the reprocess window behind it, in the ENU and LCI frames:

1. lateness below ``output_delay_s``: the released solutions are bit-identical
   to those of the time-sorted order (state, covariance, mode, counts);
2. lateness up to the reprocess window: every released solution that no
   late event could reach (none stamped at or before it arrived after it was
   released, none rejected as stale) is bit-identical; the others are counted
   (``*_after_release``, ``rejected_*_stale``);
3. a replay of the same records in any order, given the live side's
   late-input reports (``replay_order``), reproduces the arrival-order run
   bit for bit: live == offline whatever the arrival order was, for the
   released solutions and for the current-time stream (one state per IMU
   sample, issue 35: the engine runs with a fusion horizon here, so the
   output predictor carries it).

Boundary cases: a measurement exactly at an IMU stamp (before or after that
sample arrives), exactly at the window edge (stale) and just after it, after
its epoch was released (counted, applied to what is released later).
"""
from __future__ import annotations

import functools
import math
import pathlib
import random
import tempfile
from dataclasses import replace
from types import SimpleNamespace as NS

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.measurements import BaroHeight, HorizontalFix
from hyper_nav_filter.core.model_update import ModelUpdate
from hyper_nav_filter.replay_order import LateInputTracker, live_order
from hyper_nav_filter.sources import make_sources
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_workbench.graph import apply_overrides
from hyper_nav_sim.core.simulate import gnss_measurements

IMU = "imu"
DELAY_S, WINDOW_S = 0.6, 1.2            # output delay and reprocess window of these tests
FUSION_DELAY_S = 0.1                    # the fusion horizon (current-time states predicted over it)


def _cfg(cfg: FilterConfig, **kw) -> FilterConfig:
    return FilterConfig.from_dict({**cfg.as_dict(), "output_delay_s": DELAY_S, "reprocess_window_s": WINDOW_S,
                                   "fusion_delay_s": FUSION_DELAY_S, **kw})


@functools.lru_cache(maxsize=None)
def world(name: str):
    """(config, initial state, IMU arrays, events) of a short flight: events
    are (topic, core event) with stamps on and between IMU epochs."""
    if name in ("enu", "lci"):
        sc = apply_overrides(load_scenario("default"), {"duration_s": 6.0}, pathlib.Path(tempfile.mkdtemp()))
        traj = sc.trajectory()
        imu = simulate.imu_stream(sc, traj)
        ev = [(m.kind, m) for m in gnss_measurements(sc, traj)]
        rng = np.random.default_rng(7)
        for t in np.arange(0.207, 6.0, 0.5):              # aiding fixes between IMU epochs (50 Hz)
            tr = traj.truth([t])
            ev.append(("horizontal_fix", HorizontalFix(float(t), float(tr.lat_rad[0] + rng.normal(0, 1e-6)),
                                                       float(tr.lon_rad[0]), np.diag([25.0, 25.0]))))
            ev.append(("baro", BaroHeight(float(t + 0.113), float(tr.alt_m[0] + rng.normal(0, 3.0)), 9.0)))
        cfg = _cfg(sc.filter_config(), **({"mechanization_frame": "LCI"} if name == "lci" else {}))
        return cfg, sc.filter_initial_state(), imu, ev
    if name == "elastic":                                  # 24 states, model updates as events
        sc = apply_overrides(load_scenario("seed000_elastic"), {"duration_s": 5.0}, pathlib.Path(tempfile.mkdtemp()))
        traj = sc.trajectory()
        imu = simulate.imu_stream(sc, traj)
        ev = [(m.kind, m) for m in gnss_measurements(sc, traj)]
        for t, f in ((1.5, (20.0, 55.0, 113.0)), (3.02, (20.2, 55.4, 112.0))):   # one on an IMU stamp
            ev.append(("model_update", ModelUpdate.from_arrays(t, "lever_arm", ["lever_arm_natural_freq_radps"] * 3,
                                                               f, "test")))
        return _cfg(sc.filter_config()), sc.filter_initial_state(), imu, ev
    if name == "tight":                                    # 17 states, pseudoranges and rates
        sc = apply_overrides(load_scenario("seed004_tight"), {"duration_s": 8.0}, pathlib.Path(tempfile.mkdtemp()))
        traj = sc.trajectory()
        imu = simulate.imu_stream(sc, traj)
        cfg = _cfg(sc.filter_config())
        tight = next(s.tight for s in make_sources(sc.filter_source_specs(), cfg) if s.spec.type == "gnss_raw")
        ev = []
        for e in simulate.gnss_raw_stream(sc, traj):
            for eph in e.ephemeris_set:
                tight.add_ephemeris(eph)
            m = tight.measurement(e.raw())
            if m is not None:
                ev.append(("pseudorange", m))
        return cfg, sc.filter_initial_state(), imu, ev
    raise KeyError(name)


def _ns(t_s: float) -> int:
    return int(round(t_s * 1e9))


def _msg(t_s, payload):
    sec, ns = divmod(_ns(t_s), 1_000_000_000)
    return NS(header=NS(stamp=NS(sec=sec, nanosec=ns)), payload=payload)


def records(name: str) -> list:
    """The flight as (topic, message) records in time order."""
    _, _, imu, ev = world(name)
    recs = [(IMU, _msg(imu.t_s[k], k)) for k in range(len(imu.t_s))]
    recs += [(topic, _msg(e.t_s, e)) for topic, e in ev]
    return [r for _, r in sorted(((_ns(r[1].header.stamp.sec + r[1].header.stamp.nanosec * 1e-9), k), r)
                                 for k, r in enumerate(recs))]


def arrival(name: str, lateness_steps, ties) -> list:
    """An arrival order: the IMU in order; event i right after the IMU sample
    ``lateness_steps[i]`` epochs after (negative: before) the last one at or
    before its stamp; events in the same slot ordered by ``ties``."""
    _, _, imu, ev = world(name)
    t = imu.t_s
    slots = {}
    for i, (topic, e) in enumerate(ev):
        k = int(np.searchsorted(t, e.t_s + 1e-9, side="right")) - 1      # last IMU at or before the stamp
        k = min(max(k + lateness_steps[i], -1), len(t) - 1)
        slots.setdefault(k, []).append((ties[i], i))
    out = [(ev[i][0], _msg(ev[i][1].t_s, ev[i][1])) for _, i in sorted(slots.get(-1, []))]
    for k in range(len(t)):
        out.append((IMU, _msg(t[k], k)))
        out += [(ev[i][0], _msg(ev[i][1].t_s, ev[i][1])) for _, i in sorted(slots.get(k, []))]
    return out


def fly(name: str, recs, late_tracker: LateInputTracker | None = None):
    """Feed records as the node does (release after every IMU sample).
    Returns (solutions, engine, reports, affected-from time): reports are the
    late-input reports a live node would publish, ``affected`` the earliest
    stamp of an event applied after its release or rejected."""
    cfg, init, imu, _ = world(name)
    eng = FusionEngine(cfg, init)
    eng.current_log = []                  # the current-time stream
    sols, reports, affected = [], [], math.inf
    for topic, m in recs:
        e = m.payload
        t_ns = _ns(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9)
        rep, after = (late_tracker.arrival(topic, t_ns, topic == IMU, eng.last_released_t_s)
                      if late_tracker else (None, False))
        if topic == IMU:
            ok, reason = eng.add_imu(imu.t_s[e], imu.dtheta_b_rad[e], imu.dvel_b_mps[e])
            if ok and late_tracker:
                late_tracker.imu_accepted(t_ns)
            sols += eng.release()
        else:
            ok, reason = (eng.add_model_update(e) if topic == "model_update" else eng.add_measurement(e))
            if not ok or after:
                affected = min(affected, e.t_s)
        if rep is not None:
            reports.append(replace(rep, outcome=reason if not ok else ("applied_after_release" if after else "applied")))
    sols += eng.release(final=True)
    return sols, eng, reports, affected


def same(a, b) -> bool:
    """Bit-identical released solutions."""
    return (a.t_s == b.t_s and a.mode == b.mode and a.n_updates == b.n_updates and a.n_rejected == b.n_rejected
            and np.array_equal(a._src[1].x_nav, b._src[1].x_nav) and np.array_equal(a._src[1].values, b._src[1].values)
            and np.array_equal(a._src[1].P, b._src[1].P))


def assert_all_same(sa, sb):
    assert len(sa) == len(sb)
    bad = [a.t_s for a, b in zip(sa, sb) if not same(a, b)]
    assert not bad, f"{len(bad)} solutions differ, first at t = {bad[0]:.3f} s"


@functools.lru_cache(maxsize=None)
def sorted_run(name: str):
    return fly(name, records(name))[0]


def lateness(name, max_steps, min_steps=-10):
    n = len(world(name)[3])
    return st.tuples(st.lists(st.integers(min_steps, max_steps), min_size=n, max_size=n),
                     st.lists(st.integers(0, 1000), min_size=n, max_size=n))


# no shrinking (a flight per example makes it take minutes); a failure prints its seed to rerun with
SETTINGS = settings(max_examples=12, deadline=None, phases=(Phase.explicit, Phase.reuse, Phase.generate),
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
WORLDS = ("enu", "lci", "elastic", "tight")


def _steps(name, seconds):
    dt = float(np.median(np.diff(world(name)[2].t_s)))
    return int(seconds / dt + 1e-9)


@pytest.mark.parametrize("name", WORLDS)
@SETTINGS
@given(data=st.data())
def test_within_the_output_delay_released_solutions_equal_the_sorted_order(name, data):
    late, ties = data.draw(lateness(name, _steps(name, DELAY_S) - 1))
    sols, eng, _, _ = fly(name, arrival(name, late, ties))
    assert_all_same(sols, sorted_run(name))
    assert not any(k.endswith(("_after_release", "_stale")) for k in eng.counters), dict(eng.counters)


@pytest.mark.parametrize("name", WORLDS)
@SETTINGS
@given(data=st.data())
def test_up_to_the_window_only_what_late_events_reach_differs_and_replay_reproduces_it(name, data):
    late, ties = data.draw(lateness(name, _steps(name, WINDOW_S) + 2))
    arr = arrival(name, late, ties)
    live, eng, reports, affected = fly(name, arr, LateInputTracker())
    ref = sorted_run(name)
    assert len(live) == len(ref)
    for a, b in zip(live, ref):
        if a.t_s < affected - 1e-9:
            assert same(a, b), f"t = {a.t_s:.3f} s differs though no late event reached it"
    n_after = sum(v for k, v in eng.counters.items() if k.endswith("_after_release"))
    assert n_after == sum(r.outcome == "applied_after_release" for r in reports)
    # the replay: the records in any order + the reports == the live run, bit for bit
    shuffled = arr[:]
    random.Random(sum(ties)).shuffle(shuffled)
    ro = live_order(shuffled, reports, IMU)
    assert ro.missing == () and ro.placed == len(reports)
    replay, eng2, _, _ = fly(name, ro.records)
    assert_all_same(replay, live)
    # the current-time stream too: one state per IMU sample, bit for bit
    cur, cur2 = eng.current_log, eng2.current_log
    assert len(cur) == len(cur2) == len(world(name)[2].t_s)
    bad = [a.t_s for a, b in zip(cur, cur2) if not (a.t_s == b.t_s and np.array_equal(a.pred.x_nav, b.pred.x_nav)
                                                    and np.array_equal(a.pred.values, b.pred.values))]
    assert not bad, f"{len(bad)} current-time states differ, first at t = {bad[0]:.3f} s"
    # every counter but the re-processing effort (the replay need not re-process what came early)
    assert {k: v for k, v in eng2.counters.items() if k != "epochs_reprocessed"} == \
        {k: v for k, v in eng.counters.items() if k != "epochs_reprocessed"}


# ---- boundary cases ---------------------------------------------------------------------

def _one_event_world():
    cfg, init, imu, ev = world("enu")
    fixes = [e for topic, e in ev if topic == "gnss_pos"]
    return cfg, init, imu, fixes


def test_measurement_exactly_at_an_imu_stamp_before_or_after_that_sample():
    cfg, init, imu, fixes = _one_event_world()
    f = next(x for x in fixes if abs(x.t_s - 2.0) < 1e-9)
    k = int(np.argmin(np.abs(imu.t_s - f.t_s)))
    assert imu.t_s[k] == pytest.approx(f.t_s, abs=1e-12)
    out = []
    for before in (True, False):
        eng = FusionEngine(cfg, init)
        sols = []
        for j in range(len(imu.t_s)):
            if j == k and before:
                eng.add_measurement(f)
            eng.add_imu(imu.t_s[j], imu.dtheta_b_rad[j], imu.dvel_b_mps[j])
            if j == k and not before:
                eng.add_measurement(f)
            sols += eng.release()
        out.append(sols + eng.release(final=True))
    assert_all_same(*out)
    assert (out[0][k - 1].n_updates, out[0][k].n_updates) == (0, 1)     # applied at that very epoch


def test_window_edge_is_stale_just_after_it_is_applied():
    cfg, init, imu, fixes = _one_event_world()
    eng = FusionEngine(cfg, init)
    for j in range(len(imu.t_s)):
        eng.add_imu(imu.t_s[j], imu.dtheta_b_rad[j], imu.dvel_b_mps[j])
        eng.release()
    edge = eng._window_start_s()
    assert edge > 0.0
    f = fixes[0]
    assert eng.add_measurement(replace(f, t_s=edge)) == (False, "gnss_pos_stale")
    assert eng.add_measurement(replace(f, t_s=edge + 1e-6)) == (True, "ok")
    assert eng.counters["rejected_gnss_pos_stale"] == 1 and eng.counters["gnss_pos_after_release"] == 1


def test_after_release_is_counted_and_applied_to_what_is_released_later():
    """A fix 0.8 s late (output delay 0.6 s): the solutions released before it
    came lack it; everything released after it came equals the on-time run
    (the state was re-processed from its epoch); the late report lets a
    replay reproduce exactly that."""
    cfg, init, imu, fixes = _one_event_world()
    f = next(x for x in fixes if abs(x.t_s - 3.0) < 1e-9)
    ref = sorted_run("enu")
    others = sorted((x for _, x in world("enu")[3] if x is not f), key=lambda x: x.t_s)
    eng = FusionEngine(cfg, init)
    sols, i, t_rel = [], 0, None
    for j in range(len(imu.t_s)):
        eng.add_imu(imu.t_s[j], imu.dtheta_b_rad[j], imu.dvel_b_mps[j])
        while i < len(others) and others[i].t_s <= imu.t_s[j] + 1e-9:
            eng.add_measurement(others[i])
            i += 1
        if t_rel is None and imu.t_s[j] >= 3.8 - 1e-9:
            t_rel = eng.last_released_t_s
            assert eng.add_measurement(f) == (True, "ok")
        sols += eng.release()
    sols += eng.release(final=True)
    assert eng.counters["gnss_pos_after_release"] == 1 and t_rel == pytest.approx(3.18)
    assert len(sols) == len(ref)
    for a, b in zip(sols, ref):
        if a.t_s < 3.0 - 1e-9 or a.t_s > t_rel + 1e-9:
            assert same(a, b), a.t_s                   # before its epoch, and all released after it came
        else:
            assert not same(a, b), a.t_s               # released before it came: without it
