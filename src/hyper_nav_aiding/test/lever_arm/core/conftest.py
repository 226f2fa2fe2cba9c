"""Shared windows of the lever-arm learning tests: a short seed 000 elastic
flight with one pull-up doublet (it rings the bending modes) and its
perfect-model window (GNSS on the filter's own prediction at the true
frequencies, the STYLE 16 switch), so the tests see a reward with a clear
optimum at a few filter passes' cost."""
import numpy as np
import pytest

from hyper_nav_aiding.lever_arm.sim_windows import SimulatedFlight, model_consistent_window, start_window
from hyper_nav_filter.core.elastic_lever_arm import TABLE2_FREQ_RADPS, TABLE4_FREQ_RADPS
from hyper_nav_sim.core.scenario import load_scenario

TRUE = np.asarray(TABLE4_FREQ_RADPS)
INITIAL = np.asarray(TABLE2_FREQ_RADPS)


def doublet_scenario(duration_s=3.0):
    sc = load_scenario("seed000_elastic")
    sc.data["duration_s"] = duration_s
    la = sc.data["lever_arm"]
    la["natural_freq_initial_radps"] = la["natural_freq_final_radps"]      # constant Table 4 truth
    sc.data["maneuvers"] = [{"type": "climb", "t_start_s": 0.3 + 0.15 * i, "duration_s": 0.15, "delta": d}
                            for i, d in enumerate((0.03, -0.06, 0.03))]
    return sc


@pytest.fixture(scope="session")
def doublet():
    """(scenario, filter config, flight) of the doublet flight."""
    sc = doublet_scenario()
    return sc, sc.filter_config(), SimulatedFlight.from_scenario(sc)


@pytest.fixture(scope="session")
def pm_window(doublet):
    """1.5 s perfect-model window at the true frequencies, noise-free GNSS."""
    sc, cfg, fl = doublet
    return model_consistent_window(start_window(fl, cfg, 1.5), cfg, TRUE)


@pytest.fixture(scope="session")
def pm_window_noisy(doublet):
    """As pm_window with the scenario's GNSS noise (5 m, 0.1 m/s) on the fixes."""
    sc, cfg, fl = doublet
    return model_consistent_window(start_window(fl, cfg, 1.5), cfg, TRUE, np.random.default_rng(7))
