"""Which solution a magnetometer sample is matched against, by stamps alone:
the newest solution stamped at least the lag before the sample, carried
forward (second order), decided once the first solution after that point
has come; interpolation when the lag is 0; wait / stale / gap; the choice
is the same whatever order the two streams arrive in (issue 22); and the
NavState conversion's acceleration carries the seed 003 truth through its
4 g turn to within a metre."""
import random

import numpy as np
import pytest

from hyper_nav_aiding.geomag.core.matching import LocalFrame, NavPoint, predict_nav
from hyper_nav_aiding.geomag.core.nav_reference import GAP, STALE, WAIT, NavReference


def nav(t, n_m=0.0, v_n=2000.0, a_n=0.0):
    fr = LocalFrame(np.deg2rad(44.0), np.deg2rad(110.0), 26000.0)
    lat, lon = fr.to_geodetic(np.array([0.0, n_m]))
    return NavPoint(t, float(lat), float(lon), 26000.0, np.array([0.0, v_n, 0.0]), np.eye(2), 1.0,
                    np.array([0.0, a_n, 0.0]))


FR = LocalFrame(np.deg2rad(44.0), np.deg2rad(110.0), 26000.0)


def north(p):
    return FR.to_en(p.lat_rad, p.lon_rad)[1]


def test_reference_by_stamp_wait_stale_gap():
    ref = NavReference(max_gap_s=0.5, max_prediction_s=2.0, lag_s=1.0)
    assert ref.at(2.0) == (None, WAIT)
    for k in range(51):                                  # 50 Hz from t = 0.00 to 1.00, 2000 m/s north
        assert ref.add(nav(0.02 * k, 40.0 * k))
    assert not ref.add(nav(0.5, 0.0))                    # not newer: refused
    assert ref.at(2.0) == (None, WAIT)                   # the first solution after 1.0 s has not come
    p, why = ref.at(1.5)                                 # reference 0.5 s (newest <= 0.5), carried 1 s
    assert why == "" and north(p) == pytest.approx(1000.0 + 2000.0, abs=0.01)
    ref.add(nav(1.02, 2040.0))
    p, why = ref.at(2.0)                                 # now decided: the solution at 1.0 s, carried 1 s
    assert why == "" and north(p) == pytest.approx(2000.0 + 2000.0, abs=0.01)
    assert ref.at(-0.5) == (None, STALE)                 # before every kept solution
    ref.add(nav(3.0, 6000.0))
    assert ref.at(3.2) == (None, GAP)                    # reference 1.02 s and the next 1.98 s apart


def test_lag_zero_interpolates_between_the_bracketing_solutions():
    ref = NavReference(max_gap_s=0.5, max_prediction_s=2.0, lag_s=0.0)
    for k in range(5):
        ref.add(nav(1.0 + 0.02 * k, 40.0 * k))
    n, why = ref.at(1.03)
    assert why == "" and n.t_s == 1.03 and north(n) == pytest.approx(60.0, abs=1e-6)
    assert ref.at(1.2) == (None, WAIT)


def test_the_choice_does_not_depend_on_arrival_order():
    """Magnetometer samples and solutions interleaved in random orders (each
    stream in its own order, as one publisher sends it): every sample gets
    the same reference."""
    navs = [nav(0.02 * k, 40.0 * k + 3.0 * np.sin(k)) for k in range(400)]
    mags = [0.1 * k + 0.013 for k in range(70)]
    results = []
    for seed in range(6):
        rng = random.Random(seed)
        ref = NavReference(max_gap_s=0.5, max_prediction_s=2.0, lag_s=1.0)
        events = [("nav", n.t_s + rng.uniform(0, 1.5), n) for n in navs] + \
                 [("mag", t + rng.uniform(0, 1.5), t) for t in mags]
        # keep each stream in order (a single publisher): sort, then restore per-stream order
        events.sort(key=lambda e: e[1])
        nq, mq = iter(navs), iter(mags)
        waiting, got = [], {}
        for kind, _, _ in events:
            if kind == "nav":
                ref.add(next(nq))
            else:
                waiting.append(next(mq))
            while waiting:
                p, why = ref.at(waiting[0])
                if why == WAIT:
                    break
                got[waiting.pop(0)] = (why, None if p is None else (p.lat_rad, p.lon_rad))
        results.append(got)
    assert all(r == results[0] for r in results[1:])
    assert sum(1 for why, _ in results[0].values() if why == "") >= 55


def test_prediction_is_second_order():
    p = predict_nav(nav(10.0, 0.0, 2000.0, 39.0), 11.0)
    fr = LocalFrame(np.deg2rad(44.0), np.deg2rad(110.0), 26000.0)
    assert fr.to_en(p.lat_rad, p.lon_rad)[1] == pytest.approx(2000.0 + 19.5, abs=0.01)
    assert p.vel_enu_mps[1] == pytest.approx(2039.0)


def test_navstate_acceleration_carries_the_truth_through_the_turn():
    """From the true NavState at t (specific force, attitude, velocity), one
    second ahead in the 4 g turn of seed 003: within 1 m of the truth."""
    from types import SimpleNamespace as NS

    from hyper_nav_aiding.geomag.conversions import nav_point
    from hyper_nav_gnss import earth
    from hyper_nav_filter.core.attitude import C_to_quat_xyzw
    from hyper_nav_sim.core.scenario import load_scenario
    traj = load_scenario("seed003").trajectory()
    for t in (310.0, 400.0):                                  # turn onset and mid-turn
        tr = traj.truth([t, t + 1.0])
        dth, dv = traj.imu_increments(np.array([t + 0.005]), 0.01)
        q = C_to_quat_xyzw(tr.C_b_n[0])
        msg = NS(header=NS(stamp=NS(sec=int(t), nanosec=0)), lat_rad=tr.lat_rad[0], lon_rad=tr.lon_rad[0],
                 alt_m=tr.alt_m[0], vel_enu_mps=tr.vel_enu_mps[0], q_b_enu=NS(x=q[0], y=q[1], z=q[2], w=q[3]),
                 accel_b_mps2=dv[0] / 0.01, state_blocks=[], state_dim=0, covariance=[])
        p = predict_nav(nav_point(msg), t + 1.0)
        d = earth.position_error_enu_m(p.lat_rad, p.lon_rad, p.alt_m, tr.lat_rad[1], tr.lon_rad[1], tr.alt_m[1])
        plain = predict_nav(NavPoint(t, tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0], tr.vel_enu_mps[0],
                                     np.eye(2)), t + 1.0)
        d0 = earth.position_error_enu_m(plain.lat_rad, plain.lon_rad, plain.alt_m, tr.lat_rad[1], tr.lon_rad[1],
                                        tr.alt_m[1])
        assert np.linalg.norm(d) < 1.0 < np.linalg.norm(d0), (t, d, d0)
