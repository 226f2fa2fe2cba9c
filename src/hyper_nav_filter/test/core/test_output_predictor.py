"""The current-time state (issue 35, ``core.output_predictor``): the engine's
state at every IMU sample, predicted over the fusion horizon.

1. one current-time state per accepted IMU sample, stamped with it;
2. with no correction arriving it equals a plain strapdown (``core.mechanization``,
   the numpy reference) from the filter's state through the buffered samples
   (velocity to 1e-9 m/s, attitude to 1e-9 rad, position to 1e-7 m: 2e-14 of
   the Earth's radius, the rounding of lat/lon), with the estimated biases,
   under both rules;
3. through a correction: ``repropagate`` equals the strapdown from the
   corrected state; ``complementary`` moves toward it by dt / tau per
   horizon step (PX4 EKF2), with no step at the correction;
4. the released (delayed) solutions do not depend on the fusion horizon
   (bit for bit), and with no horizon the current-time state is the filter's;
5. the current-time stream is consistent: average NEES of position and
   velocity over 5 short flights in the 95 % chi-square band.
"""
from __future__ import annotations

import functools
import pathlib
import tempfile

import numpy as np
import pytest
from scipy.stats import chi2

from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import attitude_error_n_rad
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.mechanization import propagate
from hyper_nav_filter.core.nav_state import ImuSample
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario
from hyper_nav_workbench.offline_fly import fly_current
from hyper_nav_sim.core.simulate import gnss_measurements

DELAY_S = 0.2


@functools.lru_cache(maxsize=None)
def world(duration_s: float = 8.0, seed: int = 0):
    base = load_scenario("default")
    cfg = base.filter_config()
    rng = np.random.default_rng(1000 + seed)
    sc = apply_overrides(base, {
        "seed": 1000 + seed, "duration_s": duration_s,
        "imu.gyro_bias_deg_per_hr": (rng.standard_normal(3) * cfg.gyro_bias_sigma_deg_per_hr).tolist(),
        "imu.accel_bias_ug": (rng.standard_normal(3) * cfg.accel_bias_sigma_ug).tolist(),
        "filter.initial_error.pos_enu_m": (rng.standard_normal(3) * np.array(cfg.init_pos_sigma_m)).tolist(),
        "filter.initial_error.vel_enu_mps": (rng.standard_normal(3) * np.array(cfg.init_vel_sigma_mps)).tolist()},
        pathlib.Path(tempfile.mkdtemp()))
    traj = sc.trajectory()
    return sc, traj, simulate.imu_stream(sc, traj), gnss_measurements(sc, traj)


def _cfg(sc, **kw) -> FilterConfig:
    return FilterConfig.from_dict({**sc.filter_config().as_dict(), "fusion_delay_s": DELAY_S, **kw})


def _strapdown(anchor, kf, ahead):
    """The numpy reference strapdown (``mechanization.propagate``) from the
    filter snapshot ``anchor`` through the samples ``ahead``."""
    s = kf.snapshot_state(anchor)
    prev, v_prev = anchor.imu_prev, anchor.x_nav[15:18].copy()
    for imu in ahead:
        v0 = s.vel_enu_mps
        s = propagate(s, imu, prev, v_prev)
        prev, v_prev = imu, v0
    return s


def _diff(a, b):
    """(position m, velocity m/s, attitude rad) differences of two NavStates."""
    dp = earth.position_error_enu_m(a.lat_rad, a.lon_rad, a.alt_m, b.lat_rad, b.lon_rad, b.alt_m)
    return (float(np.linalg.norm(dp)), float(np.linalg.norm(a.vel_enu_mps - b.vel_enu_mps)),
            float(np.linalg.norm(attitude_error_n_rad(a.C_b_n, b.C_b_n))))


def _feed(eng, imu, meas, k_range, t_meas_until=np.inf, each=None):
    j = 0
    for k in k_range:
        t = float(imu.t_s[k])
        while j < len(meas) and meas[j].t_s + DELAY_S <= t - 1e-9:
            if meas[j].t_s <= t_meas_until:
                eng.add_measurement(meas[j])
            j += 1
        ok, _ = eng.add_imu(t, imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        assert ok
        if each is not None:
            each(k, t)


@pytest.mark.parametrize("rule", ["repropagate", "complementary"])
def test_one_state_per_sample_equal_to_a_plain_strapdown_without_corrections(rule):
    sc, traj, imu, meas = world()
    eng = FusionEngine(_cfg(sc, output_predictor=rule), sc.filter_initial_state())
    worst = np.zeros(3)
    stamps = []
    t_stop = 3.0                                  # fixes until 3 s: biases estimated, none after

    def check(k, t):
        cur = eng.current
        stamps.append(cur.t_s)
        assert cur.t_s == t
        if t < t_stop + DELAY_S + 0.5 or rule == "complementary" and t < t_stop + 2 * DELAY_S + 2.0:
            return                                # (complementary: its feedback of the last fixes decays)
        anchor = eng._epochs[-1].snap
        assert t - anchor.t_s == pytest.approx(DELAY_S, abs=0.021)
        ref = _strapdown(anchor, eng.kf, eng._ahead)
        d = _diff(cur.state, ref)
        np.maximum(worst, d, out=worst)

    _feed(eng, imu, meas, range(len(imu.t_s)), t_meas_until=t_stop, each=check)
    assert len(stamps) == len(imu.t_s) and stamps == [float(t) for t in imu.t_s]
    assert eng.kf.n_updates > 0 and np.any(eng.kf.values != 0.0)
    if rule == "repropagate":
        # measured: 1.5e-8 m (2e-15 of the Earth's radius: lat/lon rounding over 10 steps of the compiled
        # kernel vs the numpy reference), 1.9e-16 m/s, 5.9e-17 rad
        assert worst[0] < 1e-7 and worst[1] < 1e-9 and worst[2] < 1e-9, worst
    else:
        # the feedback of the last fix's correction is still decaying (dt/tau per sample)
        assert worst[0] < 1e-3 and worst[1] < 1e-5 and worst[2] < 1e-8, worst


def test_through_a_correction_repropagate_jumps_and_complementary_converges():
    sc, traj, imu, meas = world()
    engines = {r: FusionEngine(_cfg(sc, output_predictor=r), sc.filter_initial_state())
               for r in ("repropagate", "complementary")}
    n = len(imu.t_s)
    fixes = [m for m in meas if m.t_s <= 2.0] + [m for m in meas if abs(m.t_s - 5.0) < 1e-9]
    seen = {r: [] for r in engines}
    for r, eng in engines.items():
        def rec(k, t, eng=eng, r=r):
            if t >= 4.0:
                seen[r].append((t, eng.current.state, _strapdown(eng._epochs[-1].snap, eng.kf, eng._ahead)))
        _feed(eng, imu, fixes, range(n), each=rec)
    rep, comp = seen["repropagate"], seen["complementary"]
    for t, cur, ref in rep:
        assert _diff(cur, ref)[0] < 1e-7                      # always the corrected state carried forward
    t = np.array([x[0] for x in rep])
    tr = traj.truth(t)

    def err(stream):
        return np.array([earth.position_error_enu_m(s.lat_rad, s.lon_rad, s.alt_m, tr.lat_rad[i], tr.lon_rad[i],
                                                    tr.alt_m[i]) for i, (_, s, _) in enumerate(stream)])
    e_rep, e_comp = err(rep), err(comp)
    # the 5 s fix after 3 s without one (measured: a 0.32 m correction): the repropagated stream steps by it
    gap = np.linalg.norm(e_comp - e_rep, axis=1)
    k0 = int(np.argmax(gap > 0.05))
    assert k0 > 0 and t[k0] == pytest.approx(5.0 + DELAY_S, abs=0.03) and gap[k0 - 1] < 1e-3
    jump_rep = np.linalg.norm(e_rep[k0] - e_rep[k0 - 1])
    jump_comp = np.linalg.norm(e_comp[k0] - e_comp[k0 - 1])
    dt = float(imu.t_s[1] - imu.t_s[0])
    a = dt / engines["complementary"].cfg.output_tau_pos_s
    assert jump_rep > 0.2 and jump_rep == pytest.approx(gap[k0] / (1 - a), rel=0.05)
    # complementary: dt / tau of the correction per horizon step (the velocity feedback adds a little)
    assert jump_comp < 1.1 * a * jump_rep + 0.01
    for k in (5, 10, 20):
        assert gap[k0 + k] < 1.2 * (1 - a) ** k * gap[k0] + 1e-3, (k, gap[k0 + k], gap[k0])
    assert gap[k0 + 60] < 0.05 * gap[k0]
    print(f"correction {jump_rep:.2f} m: repropagate steps by it, complementary by {jump_comp:.3f} m, "
          f"{gap[k0 + 20]:.3f} m left after 20 samples")


def test_released_solutions_do_not_depend_on_the_horizon_and_no_horizon_is_the_filter_state():
    sc, traj, imu, meas = world(6.0)
    out = {}
    for delay in (0.0, DELAY_S):
        eng = FusionEngine(_cfg(sc, fusion_delay_s=delay), sc.filter_initial_state())
        sols, cur = [], []

        def rec(k, t, eng=eng):
            sols.extend(eng.release())
            cur.append(eng.current)
            if delay == 0.0:
                assert eng.current.lead_s == 0.0 and eng.current.state.lat_rad == eng.kf.state.lat_rad
        _feed(eng, imu, meas, range(len(imu.t_s)), each=rec)
        sols += eng.release(final=True)
        out[delay] = (sols, cur, eng)
    a, b = out[0.0][0], out[DELAY_S][0]
    assert len(a) == len(b) > 100
    for s, u in zip(a, b):
        assert s.t_s == u.t_s and s.mode == u.mode and s.n_updates == u.n_updates
        np.testing.assert_array_equal(s.P, u.P)
        assert s.state.lat_rad == u.state.lat_rad and np.array_equal(s.state.vel_enu_mps, u.state.vel_enu_mps)
    # with the horizon the late fixes are not late; without, every one is re-processed
    assert out[0.0][2].counters["epochs_reprocessed"] > 0 and out[DELAY_S][2].counters["epochs_reprocessed"] == 0
    # the covariance grows over the lead
    c = out[DELAY_S][1][-1]
    assert c.lead_s == pytest.approx(DELAY_S, abs=0.021)
    lay = out[DELAY_S][2].cfg.layout
    p = lay.sl("pos")
    anchor_P = out[DELAY_S][2].kf.P_enu(c.pred.anchor)
    assert np.trace(c.P[p, p]) > np.trace(anchor_P[p, p])


@pytest.mark.parametrize("rule", ["repropagate", "complementary"])
def test_current_time_stream_nees_in_the_95_percent_band(rule):
    n_runs, nees, nees_delayed = 5, [], []
    for seed in range(n_runs):
        sc, *_ = world(30.0, seed)
        cur, sols, eng, traj, _ = fly_current(sc, _cfg(sc, output_predictor=rule), DELAY_S, 30.0)
        one = []
        for stream, acc in ((cur, one), (sols, None)):
            pick = [s for s in stream if abs(s.t_s - round(s.t_s)) < 1e-9 and s.t_s >= 5.0]
            tr = traj.truth(np.array([s.t_s for s in pick]))
            lay = eng.cfg.layout
            idx = np.r_[lay.sl("pos"), lay.sl("vel")]
            vals = []
            for i, s in enumerate(pick):
                e = np.concatenate([earth.position_error_enu_m(s.state.lat_rad, s.state.lon_rad, s.state.alt_m,
                                                               tr.lat_rad[i], tr.lon_rad[i], tr.alt_m[i]),
                                    s.state.vel_enu_mps - tr.vel_enu_mps[i]])
                vals.append(e @ np.linalg.solve(s.P[np.ix_(idx, idx)], e))
            (nees if acc is not None else nees_delayed).append(vals)
    anees, anees_d = np.mean(nees, axis=0), np.mean(nees_delayed, axis=0)
    lo, hi = chi2.ppf([0.025, 0.975], n_runs * 6) / n_runs
    print(f"{rule}: ANEES (6 dof) current {anees.mean():.2f}, delayed {anees_d.mean():.2f}, band [{lo:.2f}, {hi:.2f}]")
    assert lo < anees.mean() < hi
    assert abs(anees.mean() / anees_d.mean() - 1.0) < 0.2
