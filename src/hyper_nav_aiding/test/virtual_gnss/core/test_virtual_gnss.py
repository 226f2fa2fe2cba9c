"""The virtual GNSS state machine (core.virtual_gnss): lock-loss begin and end,
malformed and expired ephemerides, stale position sources, and what a
virtual range from the fused state tells the filter."""
import dataclasses

import numpy as np
import pytest

from hyper_nav_aiding.virtual_gnss.core.virtual_gnss import VirtualGnss
from hyper_nav_aiding.virtual_gnss.core.virtual_gnss_config import VirtualGnssConfig, VirtualGnssConfigError
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_aiding.virtual_gnss.parameters import VirtualGnssNodeParams, from_scenario
from hyper_nav_filter.core.raw_to_pseudoranges import RawPseudoranges, TightGnssInput, select_channels
from hyper_nav_filter.core.nav_state import ImuSample


def _core(fl, **cfg):
    c = VirtualGnssConfig.from_config({**fl.sc.data["virtual_gnss"], **cfg})
    return VirtualGnss(c, _params(fl).corrections, rng=np.random.default_rng(0))


def _params(fl):
    return VirtualGnssNodeParams.from_values(from_scenario(fl.sc))


def _one(outs):
    assert len(outs) <= 1
    return outs[0] if outs else None


def _with_lock(raw, locked):
    return dataclasses.replace(raw, locked=np.asarray(locked, bool))


def test_lock_loss_begin_and_end_publish_nothing_stale(flight_perfect):
    """Alpha-beta source fed with the receiver's fixes while it has them.
    Epochs 1-5 all locked: nothing. 6-8: one satellite lost: a virtual
    epoch for that one only, stamped with the epoch itself. 9-13: all lost:
    every satellite ever locked. 14: lock returns on half of them: virtual
    only for the others. 15-20: all locked again: nothing. An epoch older than
    one processed is rejected and counted; every output carries its input's
    stamp and time tag, never an earlier one."""
    fl = flight_perfect
    vg = _core(fl, position_source="alpha_beta", add_noise=False)
    for eph in fl.epochs_no_loss[0].ephemeris_set:
        assert vg.add_ephemeris(eph) is None
    eps = fl.epochs_no_loss[:20]
    n = len(eps[0].sat_ids)
    outs = {}
    for k, e in enumerate(eps, start=1):
        if k <= 5 or k >= 15:
            lock = np.ones(n, bool)
        elif k <= 8:
            lock = np.arange(n) != 2
        elif k <= 13:
            lock = np.zeros(n, bool)
        else:
            lock = np.arange(n) < n // 2
        if lock.all():
            vg.add_fix(e.t_s, e.fix.r_e_m, e.fix.v_e_mps)
        raw = _with_lock(e.raw(), lock)
        out = _one(vg.on_raw(raw))
        outs[k] = out
        if out is not None:
            assert out.t_s == raw.t_s and out.t_rx_gpst_s == raw.t_rx_gpst_s
            lost = {(s, int(p)) for s, p, ok in zip(raw.system, raw.prn, raw.locked) if not ok}
            assert {(s, int(p)) for s, p in zip(out.system, out.prn)} == lost     # only the lost ones
    assert all(outs[k] is None for k in range(1, 6))
    assert all(outs[k] is not None and len(outs[k].prn) == 1 and outs[k].prn[0] == eps[0].prn[2]
               for k in range(6, 9))
    assert all(outs[k] is not None and len(outs[k].prn) == n for k in range(9, 14))
    assert len(outs[14].prn) == n - n // 2
    assert all(outs[k] is None for k in range(15, 21))
    assert vg.counters["virtual_epochs"] == 9 and vg.counters["epochs_all_locked"] == 11
    assert "after" in vg.add_raw(_with_lock(eps[5].raw(), np.zeros(n, bool)))       # older than the last epoch
    assert vg.ready() == []
    assert vg.counters["rejected_raw_out_of_order"] == 1
    # the alpha-beta extrapolation cannot follow the boost: 8 s after the last fix (t = 13 s,
    # ~3 g of thrust) the virtual ranges are hundreds of metres off the true ones (0.5 a t^2 ~ 1 km)
    err = outs[13].pseudorange_m - eps[12].pseudorange_m
    print(f"\nalpha-beta virtual - true pseudoranges 8 s after the last fix: {np.round(err - err.mean(), 0)} m")
    assert 30.0 < np.abs(err - err.mean()).max() < 2000.0


def test_no_source_no_virtual_ranges(flight_perfect):
    """Lost satellites but no position: nothing, counted, with the reason."""
    fl = flight_perfect
    for source in ("fused", "alpha_beta"):
        vg = _core(fl, position_source=source)
        for eph in fl.epochs_no_loss[0].ephemeris_set:
            vg.add_ephemeris(eph)
        raw = fl.epochs_no_loss[0].raw()
        vg.add_imu(ImuSample(raw.t_s, 0.01, np.zeros(3), np.zeros(3)))
        vg.on_raw(raw)
        lost = fl.epochs_no_loss[1].raw()
        assert vg.on_raw(_with_lock(lost, np.zeros(len(lost.prn), bool))) == []
        # fused: held while a state may still come, given up once the IMU is max_state_age_s past it
        vg.add_imu(ImuSample(lost.t_s + vg.cfg.max_state_age_s + 0.01, 0.01, np.zeros(3), np.zeros(3)))
        assert vg.ready() == []
        assert vg.counters["virtual_epochs_no_position"] == 1
        assert ("fused state" in vg.last_error) if source == "fused" else ("no receiver fix" in vg.last_error)


def test_malformed_or_expired_ephemeris_is_rejected_with_a_clear_error_and_counted(flight_perfect):
    fl = flight_perfect
    vg = _core(fl, position_source="alpha_beta")
    good = fl.epochs_no_loss[0].ephemerides[0]           # a satellite in view
    cases = [(dataclasses.replace(good, sqrtA=float("nan")), "rejected_ephemeris_malformed", "non-finite"),
             (dataclasses.replace(good, e=1.2), "rejected_ephemeris_malformed", "is not an orbit"),
             (dataclasses.replace(good, system="R"), "rejected_ephemeris_malformed", "unsupported system")]
    for eph, counter, text in cases:
        msg = vg.add_ephemeris(eph)
        assert msg is not None and text in msg and vg.counters[counter] >= 1, msg
    # expired: once the receiver's time is known, a record 3 h old is refused
    e0 = fl.epochs_no_loss[0]
    vg.add_ephemeris(good)
    vg.add_fix(e0.t_s, e0.fix.r_e_m, e0.fix.v_e_mps)
    vg.on_raw(e0.raw())
    old = dataclasses.replace(good, prn=good.prn, toe=good.toe - 3 * 3600.0, toc=good.toc - 3 * 3600.0)
    msg = vg.add_ephemeris(old)
    assert msg is not None and "expired" in msg and str(good.sat_id) in msg
    assert vg.counters["rejected_ephemeris_expired"] == 1
    # a stored record that expires during the outage: that satellite is dropped, counted, named
    vg2 = _core(fl, position_source="alpha_beta", add_noise=False)
    short = dataclasses.replace(good, toe=good.toe - 7200.0 + 15.0, toc=good.toc - 7200.0 + 15.0)
    vg2.add_ephemeris(short)
    for eph in e0.ephemeris_set:
        if eph.sat_id != good.sat_id:
            vg2.add_ephemeris(eph)
    for e in fl.epochs_no_loss[:20]:
        lock = np.ones(len(e.prn), bool) if e.t_s < 10 else np.zeros(len(e.prn), bool)
        if lock.all():
            vg2.add_fix(e.t_s, e.fix.r_e_m, e.fix.v_e_mps)
        out = _one(vg2.on_raw(_with_lock(e.raw(), lock)))
        if out is not None and e.t_s > 16.0:
            assert good.prn not in out.prn              # expired 15 s after the start: gone
    assert vg2.counters["virtual_channels_no_valid_ephemeris"] > 0 and good.sat_id in vg2.last_error


def test_bad_config_fields_are_named():
    for d, text in [({"position_source": "gps"}, "virtual_gnss.position_source: expected one of"),
                    ({"pseudorange_sigma_m": -1.0}, "virtual_gnss.pseudorange_sigma_m: must be > 0"),
                    ({"add_noise": "yes"}, "virtual_gnss.add_noise: expected true or false"),
                    ({"sigma": 1.0}, "virtual_gnss.sigma: unknown field")]:
        with pytest.raises(VirtualGnssConfigError, match=text.replace(".", r"\.")):
            VirtualGnssConfig.from_config(d)


def test_virtual_ranges_from_the_fused_state_carry_no_information_about_the_vehicle(flight_perfect):
    """Seed 004, lock lost at 10 s, the fused-state source without eq. 10's
    noise: from the second virtual epoch on, the filter's innovation, its
    common mode (the virtual node's own receiver-clock estimate minus the
    filter's) removed, is < 1 mm: the virtual range is the filter's own
    prediction, so it cannot correct position, velocity or biases. (In the
    first one, the fused state the node holds is 1 s old, the filter's
    output delay, and lacks the filter's last real update: centimetres,
    information the filter already has.) The update still shrinks the
    covariance as if it had (case (b)'s NEES in the reproduction)."""
    fl = flight_perfect
    sc = fl.sc
    cfg = sc.filter_config()
    eng = FusionEngine(cfg, sc.filter_initial_state())
    p = _params(fl)
    real = TightGnssInput(p.corrections, True, 0.5)           # the gnss_raw source's input
    vg = _core(fl, add_noise=False, input_hold_s=0.0)         # each virtual epoch at its own IMU epoch
    for eph in fl.epochs_loss[0].ephemeris_set:
        real.add_ephemeris(eph)
        vg.add_ephemeris(eph)
    imu, j, resid = fl.imu, 0, []
    psl = cfg.layout.sl("pos")
    for k in range(len(imu.t_s)):
        eng.add_imu(imu.t_s[k], imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        vg.add_imu(ImuSample(imu.t_s[k], imu.dt_s, imu.dtheta_b_rad[k], imu.dvel_b_mps[k]))
        while j < len(fl.epochs_loss) and fl.epochs_loss[j].t_s <= imu.t_s[k] + 1e-9:
            raw = fl.epochs_loss[j].raw()
            j += 1
            real.add_raw(raw)
            real.feed(eng)
            for v in vg.on_raw(raw):
                idx, ephs = select_channels(v, real.ephemerides)
                res, _, _ = RawPseudoranges(v.t_s, v, idx, ephs, real.corrections, True).model(
                    eng.kf.state, cfg.layout, type("Ctx", (), {"lever_arm_b_m": np.zeros(3), "dt_to_meas_s": 0.0}))
                pr = res[:len(idx)]
                resid.append((v.t_s, np.r_[pr - pr.mean(), res[len(idx):] - res[len(idx):].mean()]))
        for s in eng.release():
            vg.add_state(s.state, float(np.sqrt(np.trace(s.P[psl, psl]) / 3.0)))
    first = np.abs(resid[0][1]).max()
    later = max(np.abs(r).max() for _, r in resid[1:])
    print(f"\n{vg.counters['virtual_epochs']} virtual epochs from {resid[0][0]:.0f} s; max |innovation - common "
          f"mode| first {first:.1e} m, later {later:.1e}")
    assert vg.counters["virtual_epochs"] >= 9
    assert later < 1e-3 and first < 0.1
