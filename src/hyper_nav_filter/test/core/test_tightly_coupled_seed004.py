"""Tightly coupled GNSS on the seed 004 flight: the 17-state filter
(15 + receiver clock bias/drift, seed 004 eqs. 1-4) uses the pseudoranges of
whatever satellites are still locked, and stays accurate where the loosely
coupled filter, which needs a 4-satellite fix, loses most of its updates
to the dynamics-driven loss of lock (seed 004 section 2.1)."""
import pathlib
import tempfile

import numpy as np

from hyper_nav_filter.core import earth
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.measurements import GnssPosition, GnssVelocity
from hyper_nav_filter.core.tightly_coupled import Pseudoranges
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.gnss.observables import satellite_states_at_reception
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_sim.graph import apply_overrides

DURATION_S = 200.0


def pseudoranges(e) -> Pseudoranges | None:
    """Corrected pseudoranges of the locked channels: satellite clock (incl.
    relativity and TGD) added back, broadcast iono/tropo models removed,
    satellite states at transmit time from the broadcast ephemeris."""
    ok = np.asarray(e.locked, bool)
    if not ok.any():
        return None
    ephs = [eph for eph, k in zip(e.ephemerides, ok) if k]
    r_guess = e.antenna_r_e_m           # only sets the light time: 1 km off moves a satellite 1.3 cm
    r_s, v_s, cb, cd, tau, R, _ = satellite_states_at_reception(ephs, e.t_gpst_s, r_guess)
    tgd = np.array([x.tgd for x in ephs])
    sat_clk_m = 299792458.0 * (cb - tgd)
    pr = e.pseudorange_m[ok] + sat_clk_m - e.iono_model_m[ok] - e.tropo_model_m[ok]
    return Pseudoranges(e.t_s, r_s, v_s, pr, e.pr_sigma_m[ok] ** 2, np.array([]), np.array([]))


def run(mode: str):
    sc = apply_overrides(load_scenario("seed004"),
                         {"duration_s": DURATION_S, "gnss.raw.lock.outages": []},
                         pathlib.Path(tempfile.mkdtemp(prefix="tc_")))
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    epochs = simulate.gnss_raw_stream(sc, traj)
    blocks = ("att", "vel", "pos", "bg", "ba", "clk") if mode == "tight" else ("att", "vel", "pos", "bg", "ba")
    base = sc.filter_config()
    cfg = FilterConfig.from_dict({**{k: v for k, v in vars(base).items() if k not in ("layout",)},
                                  "state_blocks": blocks, "clock_bias_sigma_m": 30.0,
                                  "clock_drift_sigma_mps": 1.0,
                                  # the receiver's clock (h0 = 2e-19, h-2 = 2e-20): q_b = h0/2 c^2,
                                  # q_d = 2 pi^2 h-2 c^2
                                  "clock_bias_psd_m2ps": 0.5 * 2e-19 * 299792458.0**2,
                                  "clock_drift_psd_m2ps3": 2 * np.pi**2 * 2e-20 * 299792458.0**2})
    eng = FusionEngine(cfg, sc.filter_initial_state())
    meas = []
    for e in epochs:
        if mode == "tight":
            m = pseudoranges(e)
            if m is not None:
                meas.append(m)
        elif e.fix is not None:
            meas.append(GnssPosition(e.t_s, e.fix.lat_rad, e.fix.lon_rad, e.fix.alt_m, e.fix.cov_pos_enu_m2))
            meas.append(GnssVelocity(e.t_s, e.fix.vel_enu_mps, e.fix.cov_vel_enu_m2ps2))
    sols, j = [], 0
    for k in range(len(imu.t_s)):
        eng.add_imu(imu.t_s[k], imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        while j < len(meas) and meas[j].t_s <= imu.t_s[k] + 1e-9:
            eng.add_measurement(meas[j])
            j += 1
        sols += eng.release()
    sols += eng.release(final=True)
    t = np.array([s.t_s for s in sols])
    tr = traj.truth(t)
    pos = np.array([earth.position_error_enu_m(s.state.lat_rad, s.state.lon_rad, s.state.alt_m,
                                               tr.lat_rad[i], tr.lon_rad[i], tr.alt_m[i]) for i, s in enumerate(sols)])
    n_epochs_used = len({round(m.t_s, 6) for m in meas})
    return pos, n_epochs_used, eng, epochs


def test_tightly_coupled_beats_loosely_coupled_under_dynamics_driven_lock_loss():
    pos_tc, used_tc, eng_tc, epochs = run("tight")
    pos_lc, used_lc, _, _ = run("loose")
    rms = lambda e: float(np.sqrt(np.mean(np.sum(e**2, axis=1))))  # noqa: E731
    few = sum(1 for e in epochs if 0 < int(np.sum(e.locked)) < 4)
    print(f"epochs with 1-3 locked satellites: {few}; GNSS epochs used TC {used_tc}, LC {used_lc}; "
          f"position 3D RMS TC {rms(pos_tc):.2f} m, LC {rms(pos_lc):.2f} m, max TC {np.abs(pos_tc).max():.2f} m")
    assert few > 20                                   # the dynamics leave fewer than 4 satellites often
    assert used_tc > used_lc + 20                     # TC keeps updating through those epochs
    assert rms(pos_tc) < rms(pos_lc)
    assert rms(pos_tc) < 15.0
    st = eng_tc.kf.stats["pseudorange"]
    # Measured: ~100 of 196 pseudorange epochs pass the 0.9999 gate; the
    # rejected ones are single-satellite epochs during the boost and the
    # pull-up, where the residual grows faster than the covariance predicts;
    # the accepted ones have a mean NIS per dof of ~4 (the filter is
    # overconfident under boost dynamics: open point, see the issue note).
    print(f"pseudorange updates accepted {st[0]}, gated {st[1]}, mean NIS/dof {st[2] / max(st[0], 1):.2f}")
    assert st[0] > 0.4 * used_tc
