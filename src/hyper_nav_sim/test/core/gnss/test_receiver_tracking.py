"""The receiver's tracking option (gnss.tracking): lock as the outcome of the
1 kHz loops through a plasma blackout, unaided vs aided; off by default."""
from __future__ import annotations

import numpy as np
import pytest

from hyper_nav_sim.core.trajectory import Maneuver, Start, Trajectory
from hyper_nav_sim.core.gnss.receiver import GnssReceiverConfig, GnssReceiverSim

D2R = np.pi / 180.0
BLACKOUT = {"mode": "table", "t_s": [10.0, 12.0, 28.0, 44.0], "att_db": [0.0, 60.0, 60.0, 0.0]}   # slow return


@pytest.fixture(scope="module")
def traj():
    st = Start(26.5 * D2R, 119.0 * D2R, 30000.0, 2400.0, 0.0, 60.0 * D2R, 0.0, 0.0)
    return Trajectory(st, [Maneuver("accelerate", 0.0, 60.0, 100.0)], 60.0)


def _run(traj, mode, seed=3):
    cfg = {"start_gpst_s": "2023-01-01T04:00:00", "ionosphere": "off", "troposphere": "off",
           "tracking": {"mode": mode, "signal": {"plasma": BLACKOUT}}}
    sim = GnssReceiverSim(cfg)
    return sim.simulate(traj, np.arange(0.0, 50.0 + 1e-9, 1.0), np.random.default_rng(seed))


def test_off_by_default_and_bad_blocks():
    assert GnssReceiverConfig.from_dict({}).tracking is None
    with pytest.raises(ValueError, match="gnss.tracking.mode"):
        GnssReceiverConfig.from_dict({"tracking": {"mode": "ultra"}})
    with pytest.raises(ValueError, match="gnss.tracking.loop"):
        GnssReceiverConfig.from_dict({"tracking": {"loop": {"bn_pll_hz": 500.0}}})
    with pytest.raises(ValueError, match="unknown field"):
        GnssReceiverConfig.from_dict({"tracking": {"bandwidth": 1}})


@pytest.mark.parametrize("mode", ["unaided", "aided"])
def test_blackout_loses_and_regains_lock(traj, mode):
    ep = _run(traj, mode)
    n_locked = np.array([int(e.locked.sum()) for e in ep])
    n_sat = np.array([len(e.sat_ids) for e in ep])
    assert np.all(n_locked[1:9] == n_sat[1:9])                     # before: every channel tracks
    assert np.all(n_locked[15:28] == 0)                            # 60 dB sheath: nothing tracks
    assert all(e.fix is None for e in ep[15:28]) and ep[5].fix is not None
    e5 = ep[5]
    # reported C/N0 is the estimate, near the truth (45 +- 6 dB-Hz band of the link budget) before the blackout
    assert np.all(np.abs(e5.cn0_dbhz - e5.cn0_true_dbhz) < 1.5)
    assert np.all(e5.tracking_flags & 3 == 3) and np.all(e5.lock_time_s > 4.0)
    assert bool(np.all(e5.tracking_flags & 16)) == (mode == "aided")
    assert np.all(ep[20].tracking_flags == (16 if mode == "aided" else 0))
    # after the blackout (C/N0 back at t = 30 s) the receiver fixes again within the window
    assert any(e.fix is not None for e in ep[31:])


def test_aided_regains_lock_sooner(traj):
    first = {}
    for mode in ("unaided", "aided"):
        ep = _run(traj, mode)
        t_fix = [e.t_s for e in ep if e.t_s > 28.0 and e.fix is not None]
        first[mode] = t_fix[0]
    # C/N0 returns at ~2.8 dB/s from t = 28 s. Aided: +-3 sigma window (a few cells), 20 ms x 5 dwells,
    # narrow loops; unaided: 28 Doppler bins x FFT code search, 4 x 1 ms dwells, 15 Hz PLL.
    # Seeds 3-5 gave aided 38 s, unaided 42-43 s.
    assert first["aided"] <= 39.0
    assert first["unaided"] - first["aided"] >= 3.0


def test_shipped_blackout_scenario_configures_an_aided_receiver():
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.core.scenario import load_scenario
    rx = simulate.gnss_receiver(load_scenario("seed004_blackout"))
    tc = rx.cfg.tracking
    assert tc.mode == "aided" and tc.loop.t_coh_s == 0.02 and tc.loop.bn_pll_hz == 3.0
    assert tc.signal.plasma.attenuation_db(140.0) == 50.0 and tc.signal.plasma.attenuation_db(60.0) == 0.0
    assert rx.cfg.lock.outages == []
