"""Receiver models for real signals on synthetic numbers: ionosphere-free
combination and group delays (combinations.py, signal_delays.py), signal
plans, the RAIM statistics (raim.py) against published chi-square values,
the error model (weighting.py), and the range-bias slots and resets
(raw_to_pseudoranges.RangeBiasSlots, ErrorStateKF.apply_resets)."""
from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from hyper_nav_gnss.corrections.combinations import choose_signals, iono_free_coefficients, parse_plan
from hyper_nav_gnss.orbits.ephemeris import BroadcastEphemeris
from hyper_nav_gnss.positioning.raim import standardized_residuals, threshold
from hyper_nav_filter.core.raw_to_pseudoranges import RangeBiasSlots
from hyper_nav_gnss.observations import RawGnssEpoch
from hyper_nav_gnss.corrections.receiver_model import ReceiverModel, satellite_observations
from hyper_nav_gnss.corrections.signal_delays import group_delay_s
from hyper_nav_gnss.signals import C_MPS, frequency_hz
from hyper_nav_gnss.corrections.weighting import ErrorModel, code_sigma_m


def _eph(system="G", prn=5, tgd=-1.1e-8, tgd2=0.0, source=0):
    return BroadcastEphemeris(system, prn, 0.0, 0.0, 2295, 5153.7, 0.01, 0.96, 1.0, 0.5, 0.2, 4e-9, 0.0, -8e-9,
                              0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, tgd, iode=7, tgd2=tgd2, data_source=source)


def test_iono_free_pair_removes_a_first_order_ionosphere_and_the_gps_tgd():
    """P_s = rho + c d_s + I (f1/fs)^2: corrected for d_s and combined, the
    pair gives rho exactly; single L1 keeps I (Klobuchar's job)."""
    rho, I1 = 21_000_000.0, 7.3
    eph = _eph(tgd=-1.1e-8)
    f1, f2 = frequency_hz("G", "1C"), frequency_hz("G", "2W")
    p1 = rho + C_MPS * group_delay_s(eph, "1C") + I1
    p2 = rho + C_MPS * group_delay_s(eph, "2W") + I1 * (f1 / f2) ** 2
    a1, a2 = iono_free_coefficients("G", "1C", "2W")
    assert a1 * (p1 - C_MPS * eph.tgd) - a2 * (p2 - C_MPS * (f1 / f2) ** 2 * eph.tgd) == pytest.approx(rho, abs=1e-6)
    assert (a1, a2) == pytest.approx((2.5457, 1.5457), abs=1e-4)        # the textbook L1/L2 coefficients
    # the IF pair of raw (uncorrected) codes already carries no TGD: the LNAV clock is the L1/L2 P(Y) one
    assert a1 * (rho + C_MPS * eph.tgd) - a2 * (rho + C_MPS * (f1 / f2) ** 2 * eph.tgd) == pytest.approx(rho, abs=1e-6)
    # noise: sqrt(a1^2 + a2^2) = 2.98 for equal sigmas
    assert np.hypot(a1, a2) == pytest.approx(2.978, abs=1e-3)


def test_group_delays_per_system():
    g = _eph("G", tgd=-5e-9)
    assert group_delay_s(g, "1C") == -5e-9 and group_delay_s(g, "2L") == pytest.approx(-5e-9 * (77 / 60) ** 2)
    c = _eph("C", 21, tgd=1.3e-8, tgd2=2.0e-9)
    assert (group_delay_s(c, "2I"), group_delay_s(c, "7I"), group_delay_s(c, "6I")) == (1.3e-8, 2.0e-9, 0.0)
    e = _eph("E", 7, tgd=4.6e-9, tgd2=4.9e-9, source=513)              # I/NAV: BGD(E1,E5a), BGD(E1,E5b)
    assert group_delay_s(e, "1C") == 4.9e-9
    assert group_delay_s(e, "7Q") == pytest.approx((1575.42 / 1207.14) ** 2 * 4.9e-9)
    assert group_delay_s(e, "5Q") == pytest.approx(4.9e-9 + ((1575.42 / 1176.45) ** 2 - 1) * 4.6e-9)


def _raw(systems, prns, codes, pr, locked=None, cn0=None):
    n = len(systems)
    return RawGnssEpoch(0.0, 2295 * 604800.0 + 1000.0, tuple(systems), np.asarray(prns), np.asarray(pr, float),
                        np.ones(n), np.zeros(n), np.ones(n), np.ones(n, bool) if locked is None else np.asarray(locked),
                        tuple(codes), np.full(n, np.nan), np.zeros(n), np.full(n, 45.0) if cn0 is None else
                        np.asarray(cn0, float), np.zeros(0), np.ones(n, np.uint8), np.zeros(n))


def test_signal_plan_prefers_the_pair_and_falls_back():
    plan = parse_plan({"G": ["1C+2W", "1C"], "E": ["1X+7X"]})
    raw = _raw(["G", "G", "G", "E", "E", "C"], [5, 5, 7, 2, 2, 21], ["1C", "2W", "1C", "1X", "5X", "2I"],
               [2e7] * 6, locked=[True, True, True, True, True, True])
    c = Counter()
    ch = {f"{x.system}{x.prn}": x.codes for x in choose_signals(raw, plan, c)}
    assert ch == {"G5": ("1C", "2W"), "G7": ("1C",)}               # E02 lacks 7X: no planned choice
    assert c["satellites_without_planned_signal"] == 1 and c["signals_system_not_in_plan"] == 1
    raw2 = _raw(["G", "G"], [5, 5], ["1C", "2W"], [2e7, 2e7], locked=[True, False])
    assert [x.codes for x in choose_signals(raw2, plan)] == [("1C",)]   # L2 code invalid: L1 alone
    for bad, msg in (({"G": ["1C+1W"]}, "same band"), ({"G": ["1Cx"]}, "not a RINEX code"), ({"G": ["9C"]}, "unknown")):
        with pytest.raises(ValueError, match=msg):
            parse_plan(bad)


def test_unhealthy_satellite_is_excluded_named_and_counted():
    ok, sick = _eph("G", 5), _eph("G", 9)
    sick = type(sick)(**{**sick.__dict__, "health": 1})
    raw = _raw(["G", "G", "G"], [5, 9, 11], ["1C", "1C", "1C"], [2e7, 2.1e7, 2.2e7])
    c = Counter()
    obs = satellite_observations(raw, [ok, sick], ReceiverModel(parse_plan({"G": ["1C"]})), c)
    assert obs.sat_ids == ["G05"]
    assert c["unhealthy"] == 1 and c["unhealthy_G09"] == 1 and c["no_ephemeris"] == 1


def test_raim_threshold_and_w_test():
    # chi-square upper quantiles (Abramowitz & Stegun Table 26.8 / any table): 5 dof at 0.001: 20.515
    assert threshold(5, 1e-3) == pytest.approx(20.515, abs=1e-3)
    assert threshold(1, 0.05) == pytest.approx(3.841, abs=1e-3)
    rng = np.random.default_rng(4)
    H = np.column_stack([rng.normal(size=(9, 3)), np.ones(9)])
    H[:, :3] /= np.linalg.norm(H[:, :3], axis=1)[:, None]
    var = np.full(9, 0.25)
    x = np.array([1.0, -2.0, 0.5, 30.0])
    y = H @ x + rng.normal(0, 0.5, 9)
    y[4] += 25.0                                          # one faulty range
    xh = np.linalg.lstsq(H, y, rcond=None)[0]
    w = standardized_residuals(H, y - H @ xh, var)
    assert int(np.argmax(np.abs(w))) == 4 and abs(w[4]) > 10


def test_error_model_weights():
    em = ErrorModel("elevation")
    assert em.receiver_var_m2(np.pi / 2, 45.0) == pytest.approx(0.18)
    assert em.receiver_var_m2(np.deg2rad(10.0), 45.0) == pytest.approx(0.09 + 0.09 / np.sin(np.deg2rad(10.0)) ** 2)
    assert code_sigma_m(45.0) == pytest.approx(np.sqrt(1.61e4 * 10 ** -4.5), rel=1e-9)   # 0.71 m
    assert code_sigma_m(np.nan) == 3.0
    both = ErrorModel("elevation_cn0")
    assert both.receiver_var_m2(np.pi / 2, 30.0) == pytest.approx(1.61e4 * 1e-3)       # weak high satellite: C/N0
    with pytest.raises(ValueError, match="weighting"):
        ErrorModel("snr")


def test_range_bias_slots_keep_release_and_reset():
    """A satellite keeps its slot (and bias state) through a loss of lock
    until another satellite needs it; a newly used one takes a free slot, or
    the slot of the satellite unseen longest once that one is unseen for
    more than release_s (reset), or none (counted)."""
    s = RangeBiasSlots(3, release_s=10.0)
    slots, new = s.assign(["G01", "G02"], 0.0)
    assert slots.tolist() == [0, 1] and new == [0, 1]
    slots, new = s.assign(["G02", "G03"], 1.0)          # G01 absent 1 s: keeps its slot
    assert slots.tolist() == [1, 2] and new == [2]
    c = Counter()
    slots, new = s.assign(["G02", "G03", "G04"], 5.0, c)
    assert slots.tolist() == [1, 2, -1] and new == [] and c["range_bias_pool_full"] == 1   # G01 unseen 4 s only
    # G01 back after 19 s unseen: its own slot, not reset (a blackout's satellites keep their bias states);
    # G04 takes the slot of G02 (last seen at 5 s, unseen 15 s > 10 s: the longest unseen with G03, lower slot)
    slots, new = s.assign(["G04", "G01"], 20.0, c)
    assert slots.tolist() == [1, 0] and new == [1] and c["range_bias_slot_taken_over"] == 1
    slots, new = s.assign(["G02"], 21.0, c)            # G02 back: G03 (unseen 16 s) gives way
    assert slots.tolist() == [2] and new == [2]
    slots, new = s.assign(["G03", "G01", "G02", "G04"], 22.0, c)     # every slot in use: none for G03
    assert slots.tolist() == [-1, 0, 2, 1] and new == [] and c["range_bias_pool_full"] == 2


def test_apply_resets_restarts_a_state_and_keeps_snapshots():
    from hyper_nav_filter.core.config import FilterConfig
    from hyper_nav_filter.core.eskf import ErrorStateKF
    from hyper_nav_filter.core.nav_state import NavState
    cfg = FilterConfig.from_dict({"state_blocks": ["att", "vel", "pos", "bg", "ba", "clk", "rb"],
                                  "range_bias_sigma_m": 2.0})
    kf = ErrorStateKF(cfg, NavState(0.0, 0.5, 1.0, 100.0, np.zeros(3), np.eye(3)))
    k = cfg.layout.sl("rb").start + 3
    P = kf.P.copy()
    P[k, 6] = P[6, k] = 0.3
    kf.P = P
    kf.values = kf.values.copy()
    kf.values[k - 9] = 1.5
    snap = kf.snapshot()
    kf.apply_resets([("rb", 3, 2.5)])
    assert kf.P[k, k] == 6.25 and kf.P[k, 6] == 0.0 and kf.values[k - 9] == 0.0
    assert snap.P[k, 6] == 0.3 and snap.values[k - 9] == 1.5          # the snapshot is untouched
    assert cfg.layout.sl("rb").stop - cfg.layout.sl("rb").start == 16


def test_gnss_raw_source_signal_plan_errors_name_the_field():
    from hyper_nav_filter.core.config import FilterConfig
    from hyper_nav_filter.core.params import ConfigError
    from hyper_nav_filter.sources import make_sources, parse_sources
    cfg = FilterConfig.from_dict({"state_blocks": ["att", "vel", "pos", "bg", "ba", "clk"]})
    table = {"imu": {"type": "imu", "topic": "imu/data_raw"}, "g": {"type": "gnss_raw", "topic": "gnss/raw"}}
    for sig, msg in ((["G1C"], r"filter\.sources\.g\.signals: 'G1C' is not"),
                     (["G:1C+1W"], r"filter\.sources\.g\.signals\.G: '1C\+1W' combines two signals of the same band")):
        with pytest.raises(ConfigError, match=msg):
            make_sources(parse_sources({**table, "g": {**table["g"], "signals": sig}}), cfg)
    src = [s for s in make_sources(parse_sources({**table, "g": {**table["g"], "signals": ["G:1C+2W,1C", "E:1X"]}}),
                                   cfg) if s.TYPE == "gnss_raw"][0]
    assert src.tight.receiver.plan == {"G": (("1C", "2W"), ("1C",)), "E": (("1X",),)}


def test_sources_feeding_one_engine_share_its_range_bias_pool():
    """Two gnss_raw sources (the real receiver's and the virtual pseudoranges')
    on one engine draw from one pool of the range-bias block: the same
    satellite of the two sources gets two slots, never one slot twice."""
    from types import SimpleNamespace
    from hyper_nav_filter.core.raw_to_pseudoranges import shared_range_bias_slots
    from hyper_nav_filter.sources import make_sources, parse_sources
    eng = SimpleNamespace()
    pool = shared_range_bias_slots(eng, 4, 30.0)
    assert shared_range_bias_slots(eng, 16, 1.0) is pool and pool.n == 4 and pool.release_s == 30.0
    assert shared_range_bias_slots(SimpleNamespace(), 4, 30.0) is not pool
    real, _ = pool.assign(["gnss_raw:G05", "gnss_raw:G07"], 0.0)
    virt, _ = pool.assign(["gnss_virtual:G05"], 0.0)
    assert sorted(real.tolist() + virt.tolist()) == [0, 1, 2]
    specs = parse_sources({"imu": {"type": "imu", "topic": "imu/data_raw"},
                           "gnss_raw": {"type": "gnss_raw", "topic": "gnss/raw"},
                           "gnss_virtual": {"type": "gnss_raw", "topic": "gnss/virtual", "channels": "virtual"}})
    from hyper_nav_filter.core.config import FilterConfig
    cfg = FilterConfig.from_dict({"state_blocks": ["att", "vel", "pos", "bg", "ba", "clk", "rb"]})
    owners = [s.tight.slot_owner for s in make_sources(specs, cfg) if s.spec.type == "gnss_raw"]
    assert owners == ["gnss_raw:", "gnss_virtual:"]
