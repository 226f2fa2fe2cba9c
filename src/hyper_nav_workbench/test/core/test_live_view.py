"""core.live_view.ErrorTracker: every solution with a truth of the same stamp
gets its error record, whatever the arrival order of the two topics (issue
22: a solution recorded before its truth used to get none: 1438 of 1500)."""
import random
from types import SimpleNamespace as NS

import numpy as np
import pytest

from hyper_nav_workbench.core.live_view import ErrorTracker

MS = 1_000_000


def state(t_ms, lat_off=0.0):
    P = np.diag(np.arange(1.0, 10.0) * 1e-2)
    return NS(header=NS(stamp=NS(sec=t_ms // 1000, nanosec=(t_ms % 1000) * MS)), lat_rad=0.5 + lat_off,
              lon_rad=2.0, alt_m=30000.0, vel_enu_mps=[1.0, 1700.0, 0.0], q_b_enu=NS(x=0.0, y=0.0, z=0.0, w=1.0),
              state_dim=9, state_blocks=["att:3", "vel:3", "pos:3"], covariance=P.ravel().tolist(), mode=3,
              last_nis=1.0, n_updates=1)


def feed(events, keep=2000):
    tr = ErrorTracker(keep)
    out = []
    for kind, m in events:
        out += tr.on_truth(m) if kind == "truth" else tr.on_nav(m)
    return dict(out), tr


def test_every_pair_is_scored_whatever_the_order():
    truth = [("truth", state(t)) for t in range(0, 30000, 20)]
    nav = [("nav", state(t, 1e-7)) for t in range(0, 30000, 20)]        # ~0.64 m north
    ref, _ = feed(truth + nav)
    assert len(ref) == 1500
    for seed in range(4):
        ev = truth + nav
        random.Random(seed).shuffle(ev)
        got, tr = feed(ev)
        assert got == ref and tr.unmatched == 0
    rec = ref[1000 * MS]
    assert rec["pos_err_enu_m"][1] == pytest.approx(1e-7 * 6.36e6, rel=0.01)
    assert rec["pos_sigma_enu_m"] == pytest.approx([np.sqrt(0.07), np.sqrt(0.08), np.sqrt(0.09)])


def test_solutions_before_their_truth_wait_for_it():
    out, tr = feed([("nav", state(t)) for t in (0, 20, 40)] + [("truth", state(t)) for t in (40, 0)])
    assert sorted(out) == [0, 40 * MS] and tr.unmatched == 0


def test_memory_bound_counts_what_it_drops():
    out, tr = feed([("nav", state(t)) for t in range(0, 200, 20)], keep=4)
    assert out == {} and tr.unmatched == 6
