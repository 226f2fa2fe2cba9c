"""The engine's compiled run of in-order IMU samples (``core.fusion_run``)
against the per-sample path (``FusionEngine.add_imu_rates``): the same
released solutions bit for bit (nominal state, covariance, mode, counts),
the same counters and final filter state, with on-time GNSS fixes, late ones
(re-processing), model updates, a NaN sample, a duplicate, an out-of-order
sample and a gap in the stream; and the block-structured covariance
propagation against the dense one (issue 41)."""
from __future__ import annotations

import dataclasses
import tempfile

import numpy as np
import pytest

from hyper_nav_filter.core import fusion_run
from hyper_nav_filter.core.fast import predict as fast_predict
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.model_update import ModelUpdate
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario
from hyper_nav_sim.core.simulate import gnss_measurements

BLOCKS_21 = ("att", "vel", "pos", "bg", "ba", "sg", "sa")


def _stream(duration_s: float = 6.0, rate_hz: float = 200.0):
    sc = apply_overrides(load_scenario("default"), {"duration_s": duration_s, "imu.rate_hz": rate_hz,
                                                    "gnss.rate_hz": 1.0}, tempfile.mkdtemp(prefix="fusion_run_"))
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    dt = np.diff(np.concatenate([[0.0], imu.t_s]))
    t = imu.t_s.copy()
    w = imu.dtheta_b_rad / dt[:, None]
    f = imu.dvel_b_mps / dt[:, None]
    # a NaN sample, a duplicate stamp, an out-of-order one and a 0.6 s gap
    w[301, 1] = np.nan
    t[402] = t[401]
    t[503] = t[500]
    keep = np.ones(len(t), bool)
    keep[700:820] = False
    t, w, f = t[keep], w[keep], f[keep]
    return sc, t, np.ascontiguousarray(w), np.ascontiguousarray(f), gnss_measurements(sc, traj)


def _events(meas, t):
    """(arrival index in the IMU stream, event): fixes on time (queued before the sample at their stamp), some
    0.3 s late, and model updates."""
    out = []
    for i, m in enumerate(meas):
        k = int(np.searchsorted(t, m.t_s - 1e-9))
        out.append((k + (60 if i % 3 == 1 else 0), m))
    for t_u, late, hz in ((2.5, 0, 21.0), (4.2, 40, 19.0)):
        out.append((int(np.searchsorted(t, t_u)) + late,
                    ModelUpdate.from_arrays(t_u, "lever_arm", ["lever_arm_natural_freq_radps"] * 3, [hz, 50.0, 98.0])))
    return sorted(out, key=lambda e: e[0])


def _feed(cfg, sc, t, w, f, events, runs: bool, keep_current: bool = False):
    eng = FusionEngine(cfg, sc.filter_initial_state())
    eng.current_log = [] if keep_current else None
    sols, taken = [], 0
    ev = list(events)
    k = 0
    while k < len(t):
        while ev and ev[0][0] <= k:
            e = ev.pop(0)[1]
            (eng.add_model_update if isinstance(e, ModelUpdate) else eng.add_measurement)(e)
        end = ev[0][0] if ev else len(t)
        n = fusion_run.add_imu_rates_run(eng, t, w, f, np.arange(k, end, dtype=np.int64)) if runs else 0
        if n:
            taken += n
            k += n
        else:
            eng.add_imu_rates(float(t[k]), w[k], f[k])
            k += 1
        sols += eng.release()
    return sols + eng.release(final=True), eng, taken


@pytest.mark.parametrize("blocks", [BLOCKS_21, ("att", "vel", "pos", "bg", "ba")])
def test_compiled_run_equals_the_per_sample_path_bit_for_bit(blocks):
    sc, t, w, f, meas = _stream()
    cfg = dataclasses.replace(sc.filter_config(), state_blocks=blocks)
    events = _events(meas, t)
    ref, er, _ = _feed(cfg, sc, t, w, f, events, runs=False)
    new, en, taken = _feed(cfg, sc, t, w, f, events, runs=True)
    assert taken > 0.8 * len(t)                                   # most samples went through the compiled run
    assert en.counters == er.counters
    assert er.counters["epochs_reprocessed"] > 0 and er.counters["imu_gaps"] == 1
    assert er.counters["rejected_imu_nan"] == 1 and er.counters["rejected_imu_out_of_order"] == 1
    assert er.counters["rejected_imu_duplicate"] == 1 and er.kf.n_updates > 3
    assert len(new) == len(ref) > 100
    for a, b in zip(new, ref):
        assert a.t_s == b.t_s and a.mode == b.mode and a.sources == b.sources
        assert (a.n_updates, a.n_rejected) == (b.n_updates, b.n_rejected)
        assert np.array_equal(a.P, b.P)
        sa, sb = a.state, b.state
        assert (sa.lat_rad, sa.lon_rad, sa.alt_m) == (sb.lat_rad, sb.lon_rad, sb.alt_m)
        assert np.array_equal(sa.vel_enu_mps, sb.vel_enu_mps) and np.array_equal(sa.C_b_n, sb.C_b_n)
        assert np.array_equal(a.omega_ib_b_radps, b.omega_ib_b_radps) and np.array_equal(a.f_b_mps2, b.f_b_mps2)
    assert np.array_equal(en.kf.P, er.kf.P) and np.array_equal(en.kf.x_nav, er.kf.x_nav)
    assert np.array_equal(en.kf.last_Phi, er.kf.last_Phi)


def test_current_time_stream_through_runs_equals_the_per_sample_one():
    """The current-time state (issue 35) per sample, kept in ``current_log``,
    is the same through compiled runs as sample by sample (no horizon: the
    filter's own state at each sample), and ``current`` after a run is too."""
    sc, t, w, f, meas = _stream()
    cfg = sc.filter_config()
    events = _events(meas, t)
    _, er, _ = _feed(cfg, sc, t, w, f, events, runs=False, keep_current=True)
    _, en, taken = _feed(cfg, sc, t, w, f, events, runs=True, keep_current=True)
    assert taken > 0.8 * len(t)
    assert len(en.current_log) == len(er.current_log) == er.counters["imu_accepted"]
    for a, b in zip(en.current_log + [en.current], er.current_log + [er.current]):
        sa, sb = a.state, b.state
        assert a.t_s == b.t_s and a.mode == b.mode
        assert (sa.lat_rad, sa.lon_rad, sa.alt_m) == (sb.lat_rad, sb.lon_rad, sb.alt_m)
        assert np.array_equal(sa.vel_enu_mps, sb.vel_enu_mps) and np.array_equal(sa.C_b_n, sb.C_b_n)
        assert np.array_equal(a.P, b.P)


def test_run_is_refused_with_a_fusion_horizon():
    """With a fusion horizon the samples ahead of it feed the output predictor one by one: no run."""
    sc, t, w, f, _ = _stream()
    cfg = dataclasses.replace(sc.filter_config(), fusion_delay_s=0.1)
    eng = FusionEngine(cfg, sc.filter_initial_state())
    eng.add_imu_rates(float(t[0]), w[0], f[0])
    assert fusion_run.add_imu_rates_run(eng, t, w, f, np.arange(1, 50, dtype=np.int64)) == 0


def test_run_is_refused_outside_the_common_case():
    sc, t, w, f, _ = _stream()
    for extra in ({"mechanization_frame": "LCI"}, {"gyro_rate_error_pct": 0.1}):
        cfg = dataclasses.replace(sc.filter_config(), **extra)
        eng = FusionEngine(cfg, sc.filter_initial_state())
        eng.add_imu_rates(float(t[0]), w[0], f[0])
        assert fusion_run.add_imu_rates_run(eng, t, w, f, np.arange(1, 50, dtype=np.int64)) == 0
    eng = FusionEngine(sc.filter_config(), sc.filter_initial_state(), keep_history=True)
    eng.add_imu_rates(float(t[0]), w[0], f[0])
    assert fusion_run.add_imu_rates_run(eng, t, w, f, np.arange(1, 50, dtype=np.int64)) == 0


def test_covariance_blocks_match_dense():
    """The block-structured propagation is the dense second-order one
    reordered: the same P' and Phi to rounding (21 states, the default
    scenario's F at cruise)."""
    sc = load_scenario("default")
    cfg = dataclasses.replace(sc.filter_config(), state_blocks=BLOCKS_21)
    eng = FusionEngine(cfg, sc.filter_initial_state())
    from hyper_nav_filter.core.fast import enu as fast_enu
    sm, kf = eng.kf.sys, eng.kf
    rng = np.random.default_rng(7)
    L = rng.normal(size=(21, 21))
    P = L @ L.T * 1e-4 + kf.P
    F = sm.A.copy()
    C = fast_enu.error_core(kf.x_nav, np.array([0.3, -0.2, 9.9]), F)
    G = sm.G_const.copy()
    a = sm.fast_args
    fast_predict.couple(F, G, C, np.array([0.01, -0.02, 0.003]), np.array([0.3, -0.2, 9.9]), np.zeros(3),
                        a[5], a[6], a[7], a[8], a[10], a[11])
    P_d, Phi_d = fast_predict.propagate_covariance_dense(F, G, sm.qc, P, 0.005, False)
    P_b, Phi_b = fast_predict.propagate_covariance_blocks(F, G, sm.qc, P, 0.005)
    assert np.abs(Phi_b - Phi_d).max() <= 1e-15
    assert np.abs(P_b - P_d).max() <= 1e-14 * np.abs(P_d).max()
    assert np.array_equal(P_b, P_b.T)
