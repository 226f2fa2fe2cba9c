"""Tightly coupled GNSS on the seed 004 flight: the 17-state filter
(15 + receiver clock bias/drift, seed 004 eqs. 1-4) uses the pseudoranges of
whatever satellites are still locked, and stays accurate where the loosely
coupled filter, which needs a 4-satellite fix, loses most of its updates
to the dynamics-driven loss of lock (seed 004 section 2.1).

Scenario ``seed004_tight`` (seed 004 without the scripted outage, filter
block with ``clk`` and the receiver's clock noise); the loosely coupled run is
the same scenario with the default sources (IMU, GNSS fix and velocity) and
the 15-state layout.

Two simulated worlds (scenario ``world.model``): the realistic one (default
for flights: true ionosphere, troposphere, orbits and clocks differ from the
broadcast models the receiver removes) for the comparison with the loosely
coupled filter, and the perfect-model one (truth = the receiver's models)
for the filter's consistency, where the pseudorange noise the receiver
reports is the only error."""
import pathlib
import tempfile

import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.measurements import GnssPosition, GnssVelocity
from hyper_nav_filter.sources import DEFAULT_TABLE, make_sources
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario

DURATION_S = 200.0


def run(mode: str, world: str = "realistic", duration_s: float = DURATION_S):
    """The filter over the simulated IMU and receiver. Tight mode goes through
    the fusion node's input path (the ``gnss_raw`` source: ephemeris store, raw
    epoch -> measurement corrected inside the filter at the nominal antenna
    position and clock of its epoch), fed in the order the node receives them."""
    over = {"duration_s": duration_s, "world.model": world}
    if mode == "loose":
        over.update({"filter.sources": DEFAULT_TABLE, "filter.config.state_blocks": ["att", "vel", "pos", "bg", "ba"]})
    sc = apply_overrides(load_scenario("seed004_tight"), over, pathlib.Path(tempfile.mkdtemp(prefix="tc_")))
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    epochs = simulate.gnss_raw_stream(sc, traj)
    cfg = sc.filter_config()
    eng = FusionEngine(cfg, sc.filter_initial_state())
    tight = next((s.tight for s in make_sources(sc.filter_source_specs(), cfg) if s.spec.type == "gnss_raw"), None)
    sols, j, used = [], 0, 0
    for k in range(len(imu.t_s)):
        eng.add_imu(imu.t_s[k], imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        while j < len(epochs) and epochs[j].t_s <= imu.t_s[k] + 1e-9:
            e = epochs[j]
            j += 1
            if mode == "tight":
                for eph in e.ephemeris_set:          # gnss/ephemeris goes out before the raw epoch using it
                    tight.add_ephemeris(eph)
                tight.add_raw(e.raw())
                used += tight.feed(eng)
            elif e.fix is not None:
                eng.add_measurement(GnssPosition(e.t_s, e.fix.lat_rad, e.fix.lon_rad, e.fix.alt_m,
                                                 e.fix.cov_pos_enu_m2))
                eng.add_measurement(GnssVelocity(e.t_s, e.fix.vel_enu_mps, e.fix.cov_vel_enu_m2ps2))
                used += 1
        sols += eng.release()
    sols += eng.release(final=True)
    t = np.array([s.t_s for s in sols])
    tr = traj.truth(t)
    pos = np.array([earth.position_error_enu_m(s.state.lat_rad, s.state.lon_rad, s.state.alt_m,
                                               tr.lat_rad[i], tr.lon_rad[i], tr.alt_m[i]) for i, s in enumerate(sols)])
    return pos, used, eng, epochs


def _rms(e):
    return float(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))


@pytest.mark.slow
def test_tightly_coupled_beats_loosely_coupled_under_dynamics_driven_lock_loss():
    """Realistic world. Measured (200 s): TC 5.65 m RMS 3D (max 14 m; 192 epochs
    accepted, 4 gated), LC 89 m (9 fixes). The TC figure is set by the world's
    broadcast-model residuals (1.3 m RMS per pseudorange after the common mode,
    mostly the ionosphere) on the 2.3 satellites locked on average, which the
    filter weights with the receiver's thermal-noise sigma (0.11-0.24 m, seed
    004 eq. 11); the perfect-model world gives 0.66 m (next test). Since
    issue 37 item 5 those residuals are the default range-bias states
    (``rb32``, 2.2 m / 1500 s): measured TC 2.98 m RMS 3D (max 5.2 m; 196
    accepted, none gated, mean NIS/dof 0.83), LC 89 m."""
    pos_tc, used_tc, eng_tc, epochs = run("tight")
    pos_lc, used_lc, _, _ = run("loose")
    few = sum(1 for e in epochs if 0 < int(np.sum(e.locked)) < 4)
    print(f"epochs with 1-3 locked satellites: {few}; GNSS epochs used TC {used_tc}, LC {used_lc}; "
          f"position 3D RMS TC {_rms(pos_tc):.2f} m, LC {_rms(pos_lc):.2f} m, max TC {np.abs(pos_tc).max():.2f} m")
    assert few > 20                                   # the dynamics leave fewer than 4 satellites often
    assert used_tc > used_lc + 20                     # TC keeps updating through those epochs
    assert _rms(pos_tc) < 0.2 * _rms(pos_lc)
    assert _rms(pos_tc) < 8.0
    st = eng_tc.kf.stats["pseudorange"]
    print(f"pseudorange updates accepted {st[0]}, gated {st[1]}, mean NIS/dof {st[2] / max(st[0], 1):.2f}")
    assert st[1] <= 0.05 * used_tc


def test_tightly_coupled_is_consistent_in_the_perfect_model_world():
    """Perfect-model world (the receiver's noise is the only pseudorange error),
    the first 120 s. Measured over 200 s: 0.66 m RMS 3D (max 3.0 m); all 196 epochs pass the 0.9999 gate
    with mean NIS/dof 0.93 once the nominal receiver clock bias integrates the
    estimated drift between updates (blocks.clock.ReceiverClock.propagate);
    without that, half were gated on a common-mode clock residual."""
    pos_tc, used_tc, eng_tc, _ = run("tight", world="perfect", duration_s=120.0)
    st = eng_tc.kf.stats["pseudorange"]
    print(f"position 3D RMS {_rms(pos_tc):.2f} m; pseudorange updates accepted {st[0]}, gated {st[1]}, "
          f"mean NIS/dof {st[2] / max(st[0], 1):.2f}")
    assert _rms(pos_tc) < 2.0
    assert st[1] <= 0.02 * used_tc
    assert 0.5 < st[2] / st[0] < 1.5
