"""Raw receiver epochs + broadcast ephemerides -> corrected pseudoranges
(core.gnss.raw_to_pseudoranges), the message conversions and the tightly
coupled input of the fusion node (the ``gnss_raw`` declared source), without ROS.

The observables come from the simulator (hyper_nav_sim.core.gnss, noise-free)
on the nominal GPS + BDS constellation; the receiver side must undo exactly
what the simulator put in: satellite clock and TGD, Klobuchar, Hopfield."""
from collections import Counter
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from hyper_nav_filter import conversions
from hyper_nav_gnss import earth
from hyper_nav_filter.core.config import ConfigError, FilterConfig
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_gnss.orbits.ephemeris import shift_ephemeris
from hyper_nav_gnss.corrections.propagation import KLOBUCHAR_ALPHA_DEFAULT, KLOBUCHAR_BETA_DEFAULT
from hyper_nav_gnss.observations import EphemerisStore, MalformedGnssInput, RawGnssEpoch
from hyper_nav_filter.core.raw_to_pseudoranges import ReceiverCorrections, TightGnssInput, raw_to_pseudoranges
from hyper_nav_filter.core.measurements import ModelContext
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_filter.core.state_layout import StateLayout
from hyper_nav_filter.sources import make_sources, parse_sources
from hyper_nav_gnss.orbits.constellation import visible_satellites
from hyper_nav_gnss.orbits.nominal import gpst_from_date, nominal_constellation
from hyper_nav_sim.core.gnss.observables import compute_observables

T0 = gpst_from_date("2023-01-01T04:00:00")                    # the seed 004 epoch
LAT, LON, ALT = np.deg2rad(26.5), np.deg2rad(119.0), 30e3
R0 = earth.geodetic_to_ecef(LAT, LON, ALT)
V_ENU = np.array([1500.0, 800.0, 30.0])
V_E = earth.C_n_e(LAT, LON) @ V_ENU
CLK_B, CLK_D = 1234.5, 0.3                                    # receiver clock [m], [m/s]
ALPHA, BETA = np.array(KLOBUCHAR_ALPHA_DEFAULT), np.array(KLOBUCHAR_BETA_DEFAULT)
LAYOUT = StateLayout(("att", "vel", "pos", "bg", "ba", "clk"))


@pytest.fixture(scope="module")
def sky():
    """Noise-free observables of the GPS + BDS satellites above 5 deg, with
    Klobuchar and Hopfield delays and a receiver clock, as the simulator makes them."""
    ephs = visible_satellites(nominal_constellation(T0, ("G", "C")), R0, T0, 5.0).ephs
    obs = compute_observables(ephs, T0, R0, V_E, CLK_B, CLK_D, iono={"G": (ALPHA, BETA), "C": (ALPHA, BETA)},
                              tropo=True)
    return ephs, obs


def _raw(ephs, obs, **changes) -> RawGnssEpoch:
    n = len(ephs)
    fields = dict(t_s=10.0, t_rx_gpst_s=obs.t_tag_s, system=tuple(e.system for e in ephs),
                  prn=np.array([e.prn for e in ephs]), pseudorange_m=obs.pseudorange_m.copy(),
                  pseudorange_sigma_m=obs.pr_sigma_m.copy(), rate_mps=obs.pseudorange_rate_mps.copy(),
                  rate_sigma_mps=obs.rate_sigma_mps.copy(), locked=np.ones(n, bool))
    fields.update(changes)
    return RawGnssEpoch(**fields)


def _truth_state() -> NavState:
    return NavState(10.0, LAT, LON, ALT, V_ENU, np.eye(3), extra={"clk": np.array([CLK_B, CLK_D])})


def test_noise_free_pseudoranges_reproduce_geometric_range_plus_clock(sky):
    """Truth antenna as the nominal position: corrected pseudorange = geometric
    range (Sagnac, light time) + receiver clock to < 1 mm on all 23 GPS and BDS
    satellites, after removing 4.4-11 m of ionosphere and troposphere and the
    satellite clocks; the filter's model at the true state has zero residual
    (measured 0.07 mm pseudorange, 0.001 mm/s rate: the rate's light-time
    factor is applied)."""
    ephs, obs = sky
    assert {e.system for e in ephs} == {"G", "C"} and len(ephs) >= 12
    assert np.min(obs.iono_m + obs.tropo_m) > 1.0             # there is something to remove
    m = raw_to_pseudoranges(_raw(ephs, obs), {(e.system, e.prn): e for e in ephs}, R0,
                            ReceiverCorrections.from_params("klobuchar", ALPHA, BETA), CLK_B, use_rates=True)
    assert len(m.pseudorange_m) == len(ephs) and m.t_s == 10.0
    np.testing.assert_allclose(m.pseudorange_m, obs.geometric_range_m + CLK_B, atol=1e-3, rtol=0)
    np.testing.assert_allclose(m.pseudorange_var_m2, obs.pr_sigma_m ** 2)
    res, H, R = m.model(_truth_state(), LAYOUT, ModelContext(np.zeros(3), np.zeros(3), 0.0))
    n = len(ephs)
    assert np.max(np.abs(res[:n])) < 1e-3
    assert np.max(np.abs(res[n:])) < 1e-3
    assert H.shape == (2 * n, LAYOUT.dim)
    # the engine's measurement (corrected inside the filter at the state of its epoch) is the same
    tight = TightGnssInput(ReceiverCorrections.from_params("klobuchar", ALPHA, BETA), use_rates=True)
    for e in ephs:
        tight.add_ephemeris(e)
    meas = tight.measurement(_raw(ephs, obs))
    assert meas.kind == "pseudorange" and len(meas.channels) == n
    res2, H2, R2 = meas.model(_truth_state(), LAYOUT, ModelContext(np.zeros(3), np.zeros(3), 0.0))
    np.testing.assert_allclose(res2, res, atol=1e-6)
    np.testing.assert_array_equal(R2, R)


def test_nominal_position_and_clock_far_off_still_within_a_metre(sky):
    """The filter's nominal state instead of the truth: 300 m off in position,
    clock estimate 0 instead of 1234.5 m: the corrected pseudoranges move by
    far less than 1 m (light time, elevations for the delay models; measured 1.7 mm)."""
    ephs, obs = sky
    store = EphemerisStore(ephs)
    m = raw_to_pseudoranges(_raw(ephs, obs), store, R0 + np.array([200.0, -150.0, 170.0]),
                            ReceiverCorrections.from_params("klobuchar", ALPHA, BETA), 0.0)
    err = m.pseudorange_m - (obs.geometric_range_m + CLK_B)
    assert np.max(np.abs(err)) < 0.01
    assert len(m.rate_mps) == 0                             # rates off by default


def test_unlocked_unknown_and_unsupported_channels_dropped(sky):
    ephs, obs = sky
    pr = obs.pseudorange_m.copy()
    pr[0] = np.nan                                          # invalid value on an unlocked channel: fine
    locked = np.ones(len(ephs), bool)
    locked[0] = False
    system = (ephs[0].system, "?5") + tuple(e.system for e in ephs[2:])
    store = {(e.system, e.prn): e for e in ephs[:2] + ephs[3:]}     # no record for channel 2
    counters = Counter()
    m = raw_to_pseudoranges(_raw(ephs, obs, pseudorange_m=pr, locked=locked, system=system), store, R0,
                            ReceiverCorrections.from_params("klobuchar", ALPHA, BETA), CLK_B, counters=counters)
    assert len(m.pseudorange_m) == len(ephs) - 3
    np.testing.assert_allclose(m.pseudorange_m, obs.geometric_range_m[3:] + CLK_B, atol=1e-3, rtol=0)
    assert counters == {"channels_unlocked": 1, "channels_unsupported_system": 1, "channels_no_ephemeris": 1,
                        "channels_used": len(ephs) - 3}
    none = raw_to_pseudoranges(_raw(ephs, obs, locked=np.zeros(len(ephs), bool)), store, R0)
    assert none is None


def test_ephemeris_valid_for_the_epoch_is_chosen(sky):
    """Two records of a satellite: the one with the nearest toe is used; a
    record more than 2 h from the epoch (GPS) is not used at all."""
    ephs, obs = sky
    g = next(e for e in ephs if e.system == "G")
    later = shift_ephemeris(g, g.toe_s + 7200.0)
    stale = shift_ephemeris(g, g.toe_s - 3 * 3600.0)
    store = EphemerisStore([later, g])
    assert store.select("G", g.prn, T0 + 600.0) is g
    assert store.select("G", g.prn, T0 + 6000.0) is later
    assert EphemerisStore([stale]).select("G", g.prn, T0) is None
    assert not store.add(g) and len(store) == 2             # same (week, toe) replaces, no duplicate


def test_malformed_raw_epoch_raises_a_clear_error(sky):
    ephs, obs = sky
    store = EphemerisStore(ephs)
    pr = obs.pseudorange_m.copy()
    pr[3] = np.nan
    with pytest.raises(MalformedGnssInput, match="non-finite pseudorange_m on a locked channel"):
        raw_to_pseudoranges(_raw(ephs, obs, pseudorange_m=pr), store, R0)
    with pytest.raises(MalformedGnssInput, match="array lengths differ"):
        raw_to_pseudoranges(_raw(ephs, obs, pseudorange_sigma_m=obs.pr_sigma_m[:-1]), store, R0)
    sig = obs.pr_sigma_m.copy()
    sig[1] = 0.0
    with pytest.raises(MalformedGnssInput, match="pseudorange_sigma_m must be > 0"):
        raw_to_pseudoranges(_raw(ephs, obs, pseudorange_sigma_m=sig), store, R0)
    with pytest.raises(MalformedGnssInput, match="not an orbit"):
        store.add(replace(ephs[0], e=1.5))


def _eph_msg(e, stamp_s: int = 0):
    return SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(sec=stamp_s, nanosec=0)),
                           system=1 if e.system == "G" else 3, prn=e.prn, week=e.week, toe_s=e.toe, toc_s=e.toc,
                           sqrt_a_sqrtm=e.sqrtA, e=e.e, i0_rad=e.i0, omega0_rad=e.Omega0, omega_rad=e.omega,
                           m0_rad=e.M0, delta_n_radps=e.delta_n, idot_radps=e.idot, omega_dot_radps=e.OmegaDot,
                           cuc_rad=e.cuc, cus_rad=e.cus, crc_m=e.crc, crs_m=e.crs, cic_rad=e.cic, cis_rad=e.cis,
                           af0_s=e.af0, af1_sps=e.af1, af2_sps2=e.af2, tgd_s=e.tgd)


def _raw_msg(raw: RawGnssEpoch):
    week = int(raw.t_rx_gpst_s // 604800)
    sec = int(raw.t_s)
    return SimpleNamespace(
        header=SimpleNamespace(stamp=SimpleNamespace(sec=sec, nanosec=int(round((raw.t_s - sec) * 1e9)))),
        gps_week=week, rx_time_of_week_s=raw.t_rx_gpst_s - 604800 * week,
        system=bytes(1 if s == "G" else 3 for s in raw.system), prn=list(raw.prn),
        pseudorange_m=list(raw.pseudorange_m), pseudorange_sigma_m=list(raw.pseudorange_sigma_m),
        pseudorange_rate_mps=list(raw.rate_mps), pseudorange_rate_sigma_mps=list(raw.rate_sigma_mps),
        locked=list(raw.locked))


def test_message_conversions_round_trip(sky):
    ephs, obs = sky
    for e in ephs:
        assert conversions.gnss_ephemeris(_eph_msg(e)) == e
    raw = _raw(ephs, obs)
    back = conversions.gnss_raw(_raw_msg(raw))
    assert back.system == raw.system and back.t_s == raw.t_s
    assert abs(back.t_rx_gpst_s - raw.t_rx_gpst_s) < 1e-6
    for name in ("prn", "pseudorange_m", "pseudorange_sigma_m", "rate_mps", "rate_sigma_mps", "locked"):
        np.testing.assert_array_equal(getattr(back, name), getattr(raw, name))


def gnss_raw_source(cfg, **params):
    table = {"imu": {"type": "imu", "topic": "imu/data_raw"},
             "gnss_raw": {"type": "gnss_raw", "topic": "gnss/raw", **params}}
    return make_sources(parse_sources(table), cfg)[1]


def test_source_rejects_and_counts_malformed_messages_and_waits_for_ephemerides(sky):
    """The node's input path: a raw epoch that arrives before its ephemerides
    waits for them (or for ephemeris_wait_s of filter time); malformed raw
    and ephemeris messages are counted as rejected, never raised."""
    ephs, obs = sky
    cfg = FilterConfig(state_blocks=("att", "vel", "pos", "bg", "ba", "clk"), init_pos_sigma_m=(5.0, 5.0, 5.0))
    eng = FusionEngine(cfg, NavState(9.9, LAT, LON, ALT, V_ENU, np.eye(3)))
    h = gnss_raw_source(cfg, ephemeris_wait_s=0.5)
    raw = _raw(ephs, obs)
    assert h.on_message("main", _raw_msg(raw), eng) is None
    assert eng.counters["pseudorange_received"] == 0        # no ephemeris yet: held
    for e in ephs[:-1]:
        assert h.on_message("ephemeris", _eph_msg(e), eng) is None
    assert eng.counters["pseudorange_received"] == 0        # still one missing
    assert h.on_message("ephemeris", _eph_msg(ephs[-1]), eng) is None
    assert eng.counters["pseudorange_received"] == 1        # complete: converted and queued
    bad = _raw_msg(raw)
    bad.pseudorange_m[2] = float("nan")
    assert "non-finite pseudorange_m" in h.on_message("main", bad, eng)
    short = _raw_msg(raw)
    short.locked = short.locked[:-1]
    assert "array lengths differ" in h.on_message("main", short, eng)
    broken = _eph_msg(ephs[0])
    broken.sqrt_a_sqrtm = float("nan")
    assert "non-finite" in h.on_message("ephemeris", broken, eng)
    d = h.diagnostics()
    assert d["rejected gnss/raw"] == 2 and d["rejected gnss/ephemeris"] == 1
    assert d["received gnss/raw"] == 3 and d["processed gnss/raw"] == 1
    # an epoch whose satellite never gets a record goes out after the wait, without that channel
    h2 = gnss_raw_source(cfg)
    for e in ephs[1:]:
        h2.on_message("ephemeris", _eph_msg(e), eng)
    h2.on_message("main", _raw_msg(_raw(ephs, obs, t_s=10.5)), eng)
    assert eng.counters["pseudorange_received"] == 1
    for k in range(1, 121):                                 # IMU to t = 11.1 s > 10.5 + 0.5
        eng.add_imu(9.9 + 0.01 * k, np.zeros(3), np.array([0.0, 0.0, 9.79 * 0.01]))
        h2.on_imu(eng)
    assert eng.counters["pseudorange_received"] == 2
    assert h2.diagnostics()["gnss_raw channels_no_ephemeris"] == 1


def test_virtual_channels_come_in_through_their_own_source_with_their_own_noise(sky):
    """``channels: virtual`` takes only the is_virtual channels, ``tracked``
    only the others; ``sigma_scale`` scales their sigmas."""
    ephs, obs = sky
    cfg = FilterConfig(state_blocks=("att", "vel", "pos", "bg", "ba", "clk"))
    msg = _raw_msg(_raw(ephs, obs))
    n = len(msg.prn)
    msg.is_virtual = [i % 2 == 0 for i in range(n)]
    virt = gnss_raw_source(cfg, channels="virtual", sigma_scale=3.0)
    tracked = gnss_raw_source(cfg)
    r_v = virt._select(conversions.gnss_raw(msg), msg.is_virtual)
    r_t = tracked._select(conversions.gnss_raw(msg), msg.is_virtual)
    assert list(r_v.locked) == msg.is_virtual and list(r_t.locked) == [not v for v in msg.is_virtual]
    np.testing.assert_allclose(r_v.pseudorange_sigma_m, 3.0 * np.asarray(msg.pseudorange_sigma_m))
    msg.is_virtual = [True] * (n - 1)
    eng = FusionEngine(cfg, NavState(9.9, LAT, LON, ALT, V_ENU, np.eye(3)))
    assert "is_virtual has" in virt.on_message("main", msg, eng)


def test_gnss_raw_source_needs_the_clock_block_and_valid_parameters():
    from hyper_nav_filter.core.config import ConfigError
    tc = FilterConfig(state_blocks=("att", "vel", "pos", "bg", "ba", "clk"))
    gnss_raw_source(tc)
    gnss_raw_source(FilterConfig(state_blocks=tc.state_blocks, mechanization_frame="LCI"))   # both frames
    with pytest.raises(ConfigError, match="needs the receiver clock block 'clk'"):
        gnss_raw_source(FilterConfig())
    with pytest.raises(ConfigError, match="klobuchar_alpha: expected 4 numbers"):
        gnss_raw_source(tc, klobuchar_alpha=[1e-8, 0.0])
    with pytest.raises(ConfigError, match="ionosphere: expected one of"):
        gnss_raw_source(tc, ionosphere="nequick")
    with pytest.raises(ConfigError, match="unknown field.*did you mean 'use_rates'"):
        gnss_raw_source(tc, use_rate=True)
    assert isinstance(gnss_raw_source(tc).tight, TightGnssInput)
    assert gnss_raw_source(tc, ionosphere="off").tight.corrections.klobuchar is None


def test_scenario_gnss_raw_source_is_validated(tmp_path):
    from hyper_nav_sim.core.scenario import ScenarioError, apply_overrides, load_scenario
    table = {"imu": {"type": "imu", "topic": "imu/data_raw"}, "gnss_raw": {"type": "gnss_raw", "topic": "gnss/raw"}}
    with pytest.raises(ScenarioError, match="needs the receiver clock block 'clk'"):
        apply_overrides(load_scenario("seed004"), {"filter.sources": table}, tmp_path)
    sc = load_scenario("seed004_tight")
    assert sc.filter_config().layout.has("clk")
    p = sc.filter_sources()["gnss_raw"]
    assert p["ionosphere"] == "klobuchar" and p["klobuchar_alpha"] == list(KLOBUCHAR_ALPHA_DEFAULT)
    assert p["use_rates"] is True


def test_a_record_is_usable_from_its_reception_on(sky):
    """The store chooses among the records received (stamped) by the epoch
    (issue 22): a record that came after an epoch is not used for it,
    whatever order the messages arrived in; the tight input holds the epoch."""
    ephs, obs = sky
    g = ephs[0]
    store = EphemerisStore()
    store.add(g, received_s=10.5)
    assert store.select(g.system, g.prn, T0, received_by_s=10.0) is None
    assert store.select(g.system, g.prn, T0, received_by_s=10.5) is g
    assert store.select(g.system, g.prn, T0) is g                    # no epoch given: any record
    store.add(g, received_s=9.0)                                     # the same record again, earlier
    assert store.select(g.system, g.prn, T0, received_by_s=10.0) is g
    # through the tight input: a raw epoch at 10 s and every record received at 10.2 s
    tight = TightGnssInput(hold_s=0.5)
    for e in ephs:
        tight.add_ephemeris(e, received_s=10.2)
    raw = _raw(ephs, obs)
    tight.add_raw(raw)
    assert tight.ready(10.3) == []                                   # incomplete: held
    assert tight.ready(10.5) == [raw]                                # hold expired
    assert tight.measurement(raw) is None                            # nothing received by 10 s


def test_a_satellite_whose_record_never_comes_holds_one_epoch_per_retry_interval(sky):
    """A tracked satellite without any ephemeris (walk_0827: G18, C50) holds
    the first epoch for hold_s; the next epochs are released at once (every
    other record present) until absent_retry_s has passed, then one epoch
    waits again; once the record comes, the satellite is used."""
    ephs, obs = sky
    tight = TightGnssInput(hold_s=0.5, absent_retry_s=30.0)
    for e in ephs[1:]:                                               # ephs[0] never broadcast
        tight.add_ephemeris(e, received_s=0.0)
    first = _raw(ephs, obs, t_s=10.0)
    tight.add_raw(first)
    assert tight.ready(10.4) == []                                   # waited for
    assert tight.ready(10.5) == [first]                              # hold expired: given up
    second = _raw(ephs, obs, t_s=10.25)
    tight.add_raw(second)
    assert tight.ready(10.5) == [second]                             # not waited for
    later = _raw(ephs, obs, t_s=40.0)                                # 30 s after the give-up
    tight.add_raw(later)
    assert tight.ready(40.0) == []                                   # waited for once more
    assert tight.ready(40.5) == [later]
    assert tight.counters["epochs_held_out"] == 2
    tight.add_ephemeris(ephs[0], received_s=40.6)                    # the record comes
    last = _raw(ephs, obs, t_s=40.75)
    tight.add_raw(last)
    assert tight.ready(40.75) == [last]                              # complete
    assert tight._missing(last, waited_for=False) == []
