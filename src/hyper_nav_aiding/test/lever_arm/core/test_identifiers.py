"""Classical identifiers (core.lever_arm.identifiers) where the bound allows."""
import numpy as np
import pytest
from hyper_nav_filter.core.elastic_lever_arm import TABLE4_FREQ_RADPS

TRUE = np.asarray(TABLE4_FREQ_RADPS)

from hyper_nav_aiding.lever_arm.core import identifiers
from hyper_nav_aiding.lever_arm.core.crb import fisher_information
from hyper_nav_aiding.lever_arm.core.env import LeverArmFrequencyEnv


def test_max_likelihood_reaches_the_bound(doublet, pm_window_noisy):
    """From 1 % off Table 4 on the ringing window with 5 m / 0.1 m/s fixes,
    maximum likelihood on the innovations lands within 3 sigma of the CRB
    (CRB 0.26/0.72/8.4 % with the structure's load known) and reports the
    information sigma at its estimate (central-difference Fisher information
    there within 30 %; w3's information changes over its 9 % error)."""
    _, cfg, _ = doublet
    env = LeverArmFrequencyEnv(pm_window_noisy, cfg, TRUE * 1.01)
    res = identifiers.max_likelihood(env, 30, grid_points=0)
    crb = fisher_information(pm_window_noisy, cfg, TRUE).sigma_radps
    err = res.freqs_radps - TRUE
    print(f"\nML error {100 * err / TRUE} %, CRB {100 * crb / TRUE} %, {res.n_passes} passes, {res.note}")
    assert np.all(np.abs(err) < 3 * crb)
    np.testing.assert_allclose(res.sigma_radps, fisher_information(pm_window_noisy, cfg, res.freqs_radps).sigma_radps,
                               rtol=0.3)
    assert res.n_passes <= 31


class _Quadratic:
    """A stand-in likelihood: 1/2 (w - w_min)^T I (w - w_min), its filter pass counted."""

    def __init__(self, w_min, info):
        self.w_min, self.info = np.asarray(w_min, float), np.asarray(info, float)

    def nll(self, w):
        d = np.asarray(w, float) - self.w_min
        return 0.5 * float(d @ self.info @ d)


class _Env:
    def __init__(self, w_init, lo, hi):
        self.window = self.filter_cfg = None
        self.w_init, self.lo, self.hi = np.asarray(w_init, float), np.asarray(lo, float), np.asarray(hi, float)
        self.n_passes = 0

    def check_deadline(self):
        pass

    def evaluate(self, w):
        return -1.0


def _with_quadratic(monkeypatch, q):
    class _Pass:
        def __init__(self, w):
            self.w = w

        def neg_log_likelihood(self):
            return q.nll(self.w)

    monkeypatch.setattr(identifiers, "replay", lambda window, cfg, w: _Pass(np.asarray(w, float)))
    monkeypatch.setattr(identifiers, "_scoring_terms",
                        lambda window, cfg, w, rel_step: (q.nll(w), q.info @ (np.asarray(w) - q.w_min), q.info))


def test_an_interior_optimum_is_converged_with_its_information_sigma(monkeypatch):
    info = np.diag([4.0, 1.0, 0.25])
    _with_quadratic(monkeypatch, _Quadratic([20.0, 57.0, 92.0], info))
    res = identifiers.max_likelihood(_Env([21.0, 55.0, 95.0], [15.0, 40.0, 70.0], [30.0, 70.0, 120.0]), 60,
                                     grid_points=0)
    assert res.note == "converged", res.note
    np.testing.assert_allclose(res.freqs_radps, [20.0, 57.0, 92.0], atol=1e-6)
    np.testing.assert_allclose(res.sigma_radps, [0.5, 1.0, 2.0], rtol=1e-9)


def test_a_box_edge_answer_is_never_reported_converged(monkeypatch):
    """The likelihood's optimum for frequency 3 lies beyond the box: the
    search stops on the edge, and says so instead of "converged"."""
    _with_quadratic(monkeypatch, _Quadratic([20.0, 57.0, 150.0], np.diag([4.0, 1.0, 0.25])))
    res = identifiers.max_likelihood(_Env([21.0, 55.0, 95.0], [15.0, 40.0, 70.0], [30.0, 70.0, 120.0]), 60,
                                     grid_points=0)
    assert res.freqs_radps[2] == 120.0
    assert res.note.startswith("on the box edge (frequency 3)") and "converged" not in res.note.replace(
        "not converged", ""), res.note


def test_global_stage_reports_a_box_edge_optimum(monkeypatch):
    """With the global stage on (sweeps and three starts) the answer for an
    optimum beyond the box is still the box edge, said so, never "converged"."""
    _with_quadratic(monkeypatch, _Quadratic([20.0, 57.0, 150.0], np.diag([4.0, 1.0, 0.25])))
    res = identifiers.max_likelihood(_Env([21.0, 55.0, 95.0], [15.0, 40.0, 70.0], [30.0, 70.0, 120.0]), 300,
                                     grid_points=11, sweeps=2, n_starts=3)
    assert res.freqs_radps[2] == 120.0
    assert res.note.startswith("on the box edge (frequency 3)"), res.note


def test_global_stage_finds_the_interior_optimum_from_far_off(monkeypatch):
    """A start 20 % off every frequency: the sweeps bring it into the basin
    and the local stage converges on the optimum with its information sigma."""
    info = np.diag([4.0, 1.0, 0.25])
    _with_quadratic(monkeypatch, _Quadratic([18.0, 64.0, 80.0], info))
    res = identifiers.max_likelihood(_Env([22.0, 52.0, 100.0], [15.0, 40.0, 70.0], [30.0, 70.0, 120.0]), 300,
                                     grid_points=11, sweeps=2, n_starts=3)
    assert res.note.startswith("converged"), res.note
    np.testing.assert_allclose(res.freqs_radps, [18.0, 64.0, 80.0], atol=1e-6)
    np.testing.assert_allclose(res.sigma_radps, [0.5, 1.0, 2.0], rtol=1e-9)


@pytest.mark.parametrize("true_radps", [TABLE4_FREQ_RADPS, (19.2, 58.7, 107.5)], ids=["table4", "issue24"])
def test_max_likelihood_on_the_simulators_own_data(true_radps):
    """Issue 24: the doublet flight of the simulator's world (RK4 modes on
    the continuous load, noisy IMU, the load sensor's own noisy 400 Hz
    samples, 2 cm / 5 mm/s fixes, seed 0), a 1.5 s window, true frequencies
    the paper's Table 4 or the issue's 19.2 / 58.7 / 107.5 rad/s, the
    issue's initial guesses (+8 / -10 / +12 %), box +-25 %.

    The likelihood at the issue's edge answer (w1 0.81x, w2 1.125x the
    truth) is far worse than at the truth. Maximum likelihood (sweeps + 3
    starts) converges inside the box with all three frequencies within 3 of
    its reported sigma (measured, Table 4: 1.42 / 0.88 / 1.52 sigma, errors
    0.023 / 0.046 / 0.88 %; issue's set: 1.70 / -0.51 / -1.32 sigma). With
    the 50 Hz interval-mean load held over the whole interval (before the
    load sensor's sub-interval samples) w3 was off by -0.74 % (Table 4) and
    -1.6 % (5.2 sigma, seed 1)."""
    import dataclasses
    from hyper_nav_aiding.lever_arm.core.replay import replay
    from hyper_nav_aiding.lever_arm.sim_windows import SimulatedFlight, start_window
    from .conftest import doublet_scenario
    true = np.asarray(true_radps, float)
    sc = doublet_scenario(2.0)
    sc.data["seed"] = 0
    sc.data["lever_arm"]["natural_freq_initial_radps"] = sc.data["lever_arm"]["natural_freq_final_radps"] = \
        [float(x) for x in true]
    sc.data["gnss"]["pos_sigma_enu_m"] = [0.02] * 3
    sc.data["gnss"]["vel_sigma_enu_mps"] = [0.005] * 3
    assert sc.world_config().lever_arm_integrator == "rk4"
    cfg = sc.filter_config()
    window = start_window(SimulatedFlight.from_scenario(sc), cfg, 1.5)
    assert window.imu_load_f_b_mps2.shape[1:] == (8, 3)           # the load sensor's 8 samples per interval
    ungated = dataclasses.replace(cfg, gate_probability=1.0)
    nll_true = replay(window, ungated, true).neg_log_likelihood()
    nll_edge = replay(window, ungated, true * [0.81, 1.125, 1.0]).neg_log_likelihood()
    assert nll_edge - nll_true > 1e4, (nll_true, nll_edge)
    env = LeverArmFrequencyEnv(window, cfg, true * [1.08, 0.90, 1.12])
    res = identifiers.max_likelihood(env, 900, grid_points=41, sweeps=3, n_starts=3)
    err = res.freqs_radps - true
    print(f"\nNLL truth {nll_true:.1f}, issue's edge {nll_edge:.1f}; ML error {100 * err / true} %, sigma "
          f"{100 * res.sigma_radps / true} %, error/sigma {err / res.sigma_radps}, {res.n_passes} passes, "
          f"{res.wall_s:.1f} s, {res.note}")
    assert res.note.startswith("converged"), res.note
    assert np.all(np.abs(err) < 3.0 * res.sigma_radps), err / res.sigma_radps
    assert np.all(res.sigma_radps / true < [0.001, 0.002, 0.02])
