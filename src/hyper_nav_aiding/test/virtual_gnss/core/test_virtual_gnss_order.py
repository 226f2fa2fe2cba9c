"""The virtual GNSS core's output does not depend on the arrival order of
its inputs (issue 22): broadcast records, receiver epochs, receiver fixes,
fused states and IMU samples, each stream in its own order but interleaved
with random delays up to ``input_hold_s``, give the same virtual epochs, to
the bit, as the time-ordered stream."""
import random

import numpy as np
import pytest

from hyper_nav_aiding.virtual_gnss.core.virtual_gnss import VirtualGnss
from hyper_nav_aiding.virtual_gnss.core.virtual_gnss_config import VirtualGnssConfig
from hyper_nav_aiding.virtual_gnss.parameters import VirtualGnssNodeParams, from_scenario
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.nav_state import ImuSample


@pytest.fixture(scope="module")
def streams(flight_perfect):
    """Time-stamped inputs as the node gets them: (arrival time, stream, payload); fused
    states arrive output_delay_s after their stamp (when the fusion node releases them)."""
    fl = flight_perfect
    sc = fl.sc
    cfg = sc.filter_config()
    eng = FusionEngine(cfg, sc.filter_initial_state())
    psl = cfg.layout.sl("pos")
    imu, ev, j, sent = fl.imu, [], 0, set()
    for k in range(len(imu.t_s)):
        t = float(imu.t_s[k])
        eng.add_imu(t, imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        ev.append((t, "imu", ImuSample(t, imu.dt_s, imu.dtheta_b_rad[k], imu.dvel_b_mps[k])))
        for s in eng.release():
            ev.append((t, "state", (s.state, float(np.sqrt(np.trace(s.P[psl, psl]) / 3.0)))))
        while j < len(fl.epochs_loss) and fl.epochs_loss[j].t_s <= t + 1e-9:
            e = fl.epochs_loss[j]
            j += 1
            for eph in e.ephemeris_set:
                if (eph.system, eph.prn, eph.toe) not in sent:
                    sent.add((eph.system, eph.prn, eph.toe))
                    ev.append((e.t_s, "eph", (eph, e.t_s)))
            if e.fix is not None:
                ev.append((e.t_s, "fix", (e.t_s, e.fix.r_e_m, e.fix.v_e_mps)))
            ev.append((e.t_s, "raw", e.raw()))
    return fl, ev


def _run(fl, events, source):
    p = VirtualGnssNodeParams.from_values(from_scenario(fl.sc))
    cfg = VirtualGnssConfig.from_config({**fl.sc.data["virtual_gnss"], "position_source": source,
                                         "add_noise": True})
    vg = VirtualGnss(cfg, p.corrections, p.lever_arm_b_m, p.rate_hz, np.random.default_rng(4))
    out = []
    for _, kind, x in events:
        if kind == "imu":
            vg.add_imu(x)
        elif kind == "state":
            vg.add_state(*x)
        elif kind == "eph":
            vg.add_ephemeris(*x)
        elif kind == "fix":
            vg.add_fix(*x)
        else:
            vg.add_raw(x)
        out += vg.ready()
    return [(v.t_s, tuple(v.prn), v.pseudorange_m.tobytes(), v.rate_mps.tobytes()) for v in out], vg


def _shuffled(events, seed, max_delay_s):
    """Each non-IMU stream delayed by random amounts up to max_delay_s, kept in its own order."""
    rng = random.Random(seed)
    last, out = {}, []
    for k, (t, kind, x) in enumerate(events):
        a = t if kind == "imu" else max(t + rng.uniform(0.0, max_delay_s), last.get(kind, -np.inf))
        last[kind] = a
        out.append((a, 0 if kind == "imu" else 1, k, kind, x))
    return [(a, kind, x) for a, _, _, kind, x in sorted(out)]


@pytest.mark.parametrize("source", ["fused", "alpha_beta"])
def test_virtual_epochs_do_not_depend_on_the_arrival_order(streams, source):
    fl, events = streams
    ref, vg = _run(fl, events, source)
    assert len(ref) >= 8 and vg.counters["virtual_epochs"] == len(ref)
    hold = vg.cfg.input_hold_s
    for seed in range(3):
        got, _ = _run(fl, _shuffled(events, seed, 0.9 * hold), source)
        assert got == ref, (seed, len(got), len(ref))
