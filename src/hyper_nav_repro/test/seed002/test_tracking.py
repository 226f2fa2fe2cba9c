"""Seed 002 trackers against the simulator's flights: EKF consistency on a
non-maneuvering glide, end-to-end training lowers the loss, the shipped
L-EKF parameters reproduce the reported Table 2 figures, the reproduction's
short mode."""
import json
import pathlib

import jax
import numpy as np
import pytest
from scipy.stats import chi2

from hyper_nav_filter.core.target_tracking import filters
from hyper_nav_filter.core.target_tracking import glide_model as gm
from hyper_nav_filter.core.target_tracking import params_store
from hyper_nav_filter.core.target_tracking.config import TrackerConfig
from hyper_nav_filter.core.target_tracking.lekf import Lekf, LekfArch
from hyper_nav_filter.core.target_tracking.training import TrackSet, TrainConfig, make_eval, noisy_batch, train
from hyper_nav_repro.seed002 import reproduce as repro_seed002
from hyper_nav_repro.seed002 import training_set as td

REPO = pathlib.Path(__file__).resolve().parents[4]
RADAR_SIGMA = np.array([2000.0, 0.01, 0.01])



def _monte_carlo_inputs(tr, cfg, runs: int, seed: int = 11):
    """Radar measurements (runs, n, 3), initial scaled states drawn from the
    filter's P0 (the lift coefficient state at 0) and step lengths (n, runs)
    for ``filters.run_batch`` over a track."""
    n = len(tr.t_s)
    rng = np.random.default_rng(seed)
    Z = tr.x[None, :, :3] + RADAR_SIGMA * rng.standard_normal((runs, n, 3))
    x0 = gm.to_scaled(tr.x[0])[None] + rng.standard_normal((runs, 7)) * np.sqrt(np.diag(cfg.P0))
    x0[:, 6] = 0.0
    DT = np.ones((n, runs))
    DT[0] = 0.0
    return Z, x0, DT

def test_ekf_is_consistent_on_a_non_maneuvering_glide():
    """30 Monte Carlo runs of radar noise over a 700 s glide at c_l = 0.3 (no
    lateral maneuver) flown by the simulator (rotating WGS-84 Earth, US76):
    the filter's Q covers its model's mismatch (exponential atmosphere,
    sphere, no Coriolis) as white noise. The MC-averaged NEES of the six
    kinematic states, 30 * NEES ~ chi2(180), stays in its 95 % band."""
    flight = {**td.vehicle(), "duration_s": 700.0, "end_speed_mps": 2000.0, "c_l_program": 0.3, "maneuvers": [],
              "start": {"lat_deg": 5.0, "lon_deg": 30.0, "alt_m": 47000.0, "speed_mps": 6900.0, "gamma_deg": -0.1,
                        "psi_deg": 60.0}}
    tr = td.fly(flight)
    cfg = TrackerConfig(filter_type="EKF", nominal_c_l=0.3, q_h_m=1.0, q_lonlat_rad=1e-7, q_v_mps=3.0,
                        q_gamma_rad=1e-3, q_psi_rad=5e-4, q_chi=0.01, init_sigma_chi=0.01)
    runs, n = 30, len(tr.t_s)
    Z, x0, DT = _monte_carlo_inputs(tr, cfg, runs)
    _, out = filters.run_batch(filters.build_filter(cfg), x0, np.repeat(cfg.P0[None], runs, 0),
                               np.swapaxes(gm.measurement_to_scaled(Z), 0, 1), DT)
    e = np.asarray(out["x"], float)[..., :6] - gm.to_scaled(tr.x)[:, None, :6]
    P = np.asarray(out["P"], float)[..., :6, :6]
    nees = np.einsum("tbi,tbij,tbj->tb", e, np.linalg.inv(P), e).mean(axis=1)[100:]
    lo, hi = chi2.ppf([0.025, 0.975], 6 * runs) / runs
    assert lo < nees.mean() < hi, (lo, nees.mean(), hi)            # measured 5.73 in [4.82, 7.30]
    assert np.mean((nees > lo) & (nees < hi)) > 0.6                # measured 0.75 of the epochs


def _glide_track():
    flight = {**td.vehicle(), "duration_s": 700.0, "end_speed_mps": 2000.0, "c_l_program": 0.3, "maneuvers": [],
              "start": {"lat_deg": 5.0, "lon_deg": 30.0, "alt_m": 47000.0, "speed_mps": 6900.0, "gamma_deg": -0.1,
                        "psi_deg": 60.0}}
    return td.fly(flight)


def _augmented_glide_nees(name, seed):
    """MC-averaged NEES (epochs 100-700 s) and RMS h, v of the augmented
    filter ``name`` (the scenario's tracker_augmented block) over 10 runs of
    radar noise and hand-over error on the 700 s glide above (simulated world)."""
    from hyper_nav_filter.core.target_tracking import augmented as au
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_sim.core.tracking_setup import tracker_config
    sc = load_scenario("seed002_s1")
    cfg = tracker_config(sc)
    setup = au.AugmentedSetup.from_dict(sc.data["tracker_augmented"])
    tr = _glide_track()
    runs, n = 10, len(tr.t_s)
    rng = np.random.default_rng(seed)
    Z = tr.x[None, :, :3] + RADAR_SIGMA * rng.standard_normal((runs, n, 3))
    x0 = tr.x[0, :6][None] + rng.standard_normal((runs, 6)) * np.sqrt(np.diag(cfg.P0))[:6] * gm.STATE_SCALE[:6]
    DT = np.ones(n)
    DT[0] = 0.0
    xa, P, _ = au.aug_filter_run(cfg.model, setup.filter_config(name), x0, cfg.P0, cfg.R,
                                 np.swapaxes(gm.measurement_to_scaled(Z), 0, 1), DT)
    e = (xa[..., :6] - tr.x[:, None, :6]) / gm.STATE_SCALE[:6]
    nees = np.einsum("tbi,tbi->tb", e, np.linalg.solve(P[..., :6, :6], e[..., None])[..., 0]).mean(axis=1)[100:]
    rms = np.sqrt(np.mean((e * gm.STATE_SCALE[:6]) ** 2, axis=(0, 1)))
    return nees, rms, chi2.ppf([0.025, 0.975], 6 * runs) / runs


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_augmented_ekf_is_consistent_on_a_non_maneuvering_glide(seed):
    """The EKF on the augmented state (maneuver parameters a_v, a_l, c_d as
    random walks; the AUG-IMM's glide mode alone): 10 * NEES ~ chi2(60), the
    mean over epochs in the 95 % band [4.05, 8.33] (measured, seeds 11/12/13:
    4.85 / 4.11 / 5.39, 92 / 53 / 93 % of epochs in band), and it tracks better
    than the EKF with the scenario's Q (h 336-358 m, v 41-58 m/s; EKF 633-642 m,
    109-124 m/s)."""
    nees, rms, (lo, hi) = _augmented_glide_nees("AUG-EKF", seed)
    assert lo < nees.mean() < hi, (lo, nees.mean(), hi)
    assert rms[0] < 500.0 and rms[3] < 80.0, rms


@pytest.mark.xfail(strict=False, reason="issue 24: the two-mode AUG-IMM is conservative on a glide (measured NEES "
                                        "3.77 / 3.82 / 4.34, v 243-260 m/s): its mode probabilities stay near "
                                        "their prior (one-step innovations at 64 km of radar noise hardly tell the modes "
                                        "apart) and the maneuver mode's estimates widen the mixture")
@pytest.mark.parametrize("seed", [11, 12, 13])
def test_augmented_imm_is_consistent_on_a_non_maneuvering_glide(seed):
    nees, rms, (lo, hi) = _augmented_glide_nees("AUG-IMM", seed)
    assert lo < nees.mean() < hi, (lo, nees.mean(), hi)
    assert rms[3] < 120.0, rms


# NEES of the AUG-IMM on the reproduction's runs (20, generator stream 2002) and on a
# draw the scenario's densities were not chosen on (stream 2302), measured:
# S1 4.66 / 4.92, S2 5.09 / 5.06, S3 5.27 / 5.45, weave 5.07 / 5.19, reversal 6.77 / 6.92
@pytest.mark.parametrize("stream", [2002, 2302])
@pytest.mark.parametrize("num", [1, 2, 3, 4, 5])
def test_augmented_imm_nees_in_band_on_the_reproduction_scenarios(num, stream):
    """Issue 24's goal: the AUG-IMM (the scenario's tracker_augmented block)
    over 20 Monte Carlo runs of radar noise and hand-over error on the
    simulated world's flight (the paper's three scenarios and the two unseen
    maneuvers): 20 * NEES ~ chi2(120) per epoch, the mean over the epochs
    after 30 s inside the 95 % band [4.58, 7.61], and RMSE h, v within 1.5x
    of the unknown-maneuver PCRB's figures in results/seed002 (S1 501 m /
    294 m/s ... reversal 566 m / 275 m/s)."""
    from hyper_nav_filter.core.target_tracking import augmented as au
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_sim.core.tracking_setup import tracker_config
    sc = load_scenario(repro_seed002.SCENARIOS[num])
    cfg = tracker_config(sc)
    t, x_true, _, Z, x0b = repro_seed002.monte_carlo_inputs(sc, cfg, 20, stream=stream)
    setup = au.AugmentedSetup.from_dict(sc.data["tracker_augmented"])
    xa, Pa, _ = au.aug_filter_run(cfg.model, setup.filter_config("AUG-IMM"), gm.to_physical(x0b), cfg.P0, cfg.R,
                                  np.swapaxes(gm.measurement_to_scaled(Z), 0, 1), np.diff(t, prepend=0.0))
    e = repro_seed002.state_errors(np.swapaxes(xa, 0, 1), x_true[None])
    res = repro_seed002.nees_summary(e, np.swapaxes(Pa, 0, 1), t)
    lo, hi = res["nees_band"]
    assert lo < res["nees_mean"] < hi, (num, stream, res["nees_mean"], lo, hi)
    rmse = np.sqrt(np.mean(e**2, axis=1)).mean(0)
    bound_h_v = {1: (501.4, 294.0), 2: (614.2, 376.5), 3: (577.7, 369.5), 4: (587.7, 395.0), 5: (565.6, 274.5)}[num]
    assert rmse[0] < 1.5 * bound_h_v[0] and rmse[3] < 1.5 * bound_h_v[1], (num, rmse)


def test_scenario_q_makes_the_ekf_conservative_on_a_glide():
    """The EKF's NEES 3.85 below [4.05, 8.33] reported in issue 24 is its
    process noise: with the scenario's Q (grid-searched for weighted MAE on
    maneuvering training tracks; shared with the L-EKF, trained with it) the
    NEES on the glide above is below the band (measured 2.85 on seed 11), with
    the glide Q of the EKF test above in it (5.85). The scenario's Q is kept
    (the L-EKF's parameters were trained with it; docs/tracking.md)."""
    from dataclasses import replace
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_sim.core.tracking_setup import tracker_config
    cfg = replace(tracker_config(load_scenario("seed002_s1")), filter_type="EKF")
    tr = _glide_track()
    runs, n = 10, len(tr.t_s)
    Z, x0, DT = _monte_carlo_inputs(tr, cfg, runs)
    lo, hi = chi2.ppf([0.025, 0.975], 6 * runs) / runs
    out_nees = []
    for c in (cfg, replace(cfg, q_v_mps=3.0, q_gamma_rad=1e-3, q_psi_rad=5e-4, q_chi=0.01, init_sigma_chi=0.01)):
        _, out = filters.run_batch(filters.build_filter(c), x0, np.repeat(c.P0[None], runs, 0),
                                   np.swapaxes(gm.measurement_to_scaled(Z), 0, 1), DT)
        e = np.asarray(out["x"], float)[..., :6] - gm.to_scaled(tr.x)[:, None, :6]
        P = np.asarray(out["P"], float)[..., :6, :6]
        out_nees.append(np.einsum("tbi,tbij,tbj->tb", e, np.linalg.inv(P), e).mean(axis=1)[100:].mean())
    assert out_nees[0] < lo < out_nees[1] < hi, (lo, out_nees, hi)


@pytest.mark.slow
def test_training_through_the_filter_lowers_the_loss():
    """End-to-end training (RMSprop, weighted MAE, TBPTT through the L-EKF
    recursion) on four short simulated glides: the loss on those tracks (fixed
    noise, running BN averages) falls below the untrained L-EKF's, which is
    the EKF's."""
    rng = np.random.default_rng(3)
    flights = [td.random_flight(np.random.default_rng([77, i])) for i in range(4)]
    for f in flights:
        f["duration_s"] = 160.0
    tracks = [td.fly(f) for f in flights]
    X, U, L = td.stack(tracks)
    cfg = TrackerConfig(q_v_mps=30.0, q_gamma_rad=3e-3, q_psi_rad=3e-2)
    arch = LekfArch(imn_dense=(8, 4), imn_lstm=(8, 8), gmn_dense=(8, 4), gmn_lstm=(8, 8))
    net = Lekf(cfg.model, cfg.u_nominal, cfg.Q, cfg.R, arch)
    ts = TrackSet(gm.to_scaled(X), np.clip(U, 1e-3, np.asarray(arch.imn_output_range) * cfg.u_nominal * 0.999), L, 1.0)
    v0 = net.init_variables(jax.random.PRNGKey(0))
    evaluate = make_eval(net)
    batch = noisy_batch(ts, np.arange(4), cfg.R, cfg.P0, rng)

    def loss(v):
        x0, P0b, Z, DT, valid, Xs, Us = batch
        return float(evaluate(v, net.init_carry(x0, P0b), Z, DT, valid, Xs, Us)[0])

    before = loss(v0)
    v1, hist = train(net, v0, ts, ts, TrainConfig(epochs=6, batch=4, chunk=40, learning_rate=3e-3), cfg.P0,
                     log=lambda *_: None)
    after = loss(v1)
    assert after < 0.9 * before, (before, after, hist)


def _table2():
    return json.loads((REPO / "results" / "seed002" / "table2.json").read_text())


def test_shipped_lekf_reproduces_the_reported_run0_figures():
    """The committed parameter set, run on each scenario's own radar stream
    (run 0 of the reproduction), gives the RMSE recorded in the committed
    results/seed002/table2.json (docs/tracking.md table) within 1 %."""
    table = _table2()
    arch, variables, meta = params_store.load("lekf_seed002")
    assert meta["data"]["data_seed"] == table["lekf_data_seed"]
    got = repro_seed002.lekf_run0_rmse([1, 2, 3], (arch, variables))
    for i, num in enumerate((1, 2, 3)):
        rec = table["scenarios"][str(num)]["filters"]["LEKF"]["rmse_runs"][0]
        np.testing.assert_allclose(got[i], rec, rtol=1e-2)


def test_reproduction_short_mode_runs(tmp_path):
    assert repro_seed002.main(["--short", "--out", str(tmp_path)]) == 0
    res = json.loads((tmp_path / "table2.json").read_text())["scenarios"]["1"]
    assert (tmp_path / "scenario1_errors.png").stat().st_size > 10_000
    for ft in repro_seed002.FILTERS:
        r = np.asarray(res["filters"][ft]["rmse_mean"])
        assert np.all(np.isfinite(r)) and res["filters"][ft]["ms_per_step"] > 0
    # the bound is an expectation: 3 runs of 200 s are too few to compare with it
    # (the full reproduction's ratios are 1.5-16, docs/tracking.md); here it must be finite
    assert np.all(np.isfinite(res["pcrb_rms"])) and np.all(np.asarray(res["pcrb_rms"]) > 0)
    # the bounds: with the maneuver unknown the bound can only rise; the known-maneuver bound of
    # the augmented model (the truth's model-equivalent parameters) is pcrb's (flown c_l and bank)
    # within 5 % (measured 1.8 % here, up to 4.7 % over the full flights)
    known, unknown = np.asarray(res["pcrb_known_rms"]), np.asarray(res["pcrb_unknown_rms"])
    assert np.all(unknown >= known * (1 - 1e-9)) and np.all(np.isfinite(unknown))
    np.testing.assert_allclose(known, res["pcrb_rms"], rtol=5e-2)
    assert res["filters"]["AUG-IMM"]["data"].startswith("simulated world")
    assert res["perfect_model"]["data"].startswith("perfect model")
    # 200 s of scenario 1 (no maneuver yet): every filter tracks within 3 km / 100 m/s, but the
    # AUG-IMM within 200 m/s (measured 171 m/s, 3 runs: its maneuver mode keeps a large share of
    # the probability on a glide and its drag walk of 1.6/sqrt(s) widens v, docs/tracking.md;
    # the others 73-95 m/s)
    for ft in repro_seed002.ALL_FILTERS:
        r = res["filters"][ft]["rmse_mean"]
        assert r[0] < 3000.0 and r[3] < (200.0 if ft == "AUG-IMM" else 100.0), (ft, r)


def test_committed_table_has_no_ratio_below_a_bound():
    """Issue 40's goal on the committed results/seed002/table2.json: against
    every column called a bound (the known-maneuver PCRB; bounds.IS_BOUND) no
    filter's RMSE ratio is below 1 beyond the Monte Carlo's 95 % interval, on
    the simulated world and the perfect model (measured: smallest 1.55
    [1.36, 1.72], L-EKF S2 gamma); the random-walk PCRB and the unbiased-only
    CRB are labelled as no bounds of these flights."""
    from hyper_nav_repro.seed002 import bounds
    table = _table2()
    assert table["runs"] == 20 and not table["short"]
    for num, res in table["scenarios"].items():
        assert "NOT a bound" in res["bounds"]["what"]["random_walk"]
        assert "NOT a bound" in res["bounds"]["what"]["windowed_flight"]
        rows = [res["filters"][ft] for ft in repro_seed002.ALL_FILTERS]
        rows += [res["perfect_model"][ft] for ft in repro_seed002.AUG_FILTERS]
        for row in rows:
            for key in bounds.BOUND_KEYS:
                if "NOT" in bounds.IS_BOUND[key]:          # the references (random walk, unbiased-only CRB)
                    continue
                hi = np.asarray(row["ratios"][key]["ci95"][1])
                assert np.all(hi >= 1.0), (num, key, row["ratios"][key])


def test_random_walk_pcrb_holds_on_draws_from_its_walks():
    """The unknown-maneuver PCRB where it must hold: 20 parameter paths drawn
    from the AUG-IMM's random walks (glide / maneuver densities on scenario
    1's mode sequence, first 300 s), flown by eq. 21, radar noise and
    hand-over error; the AUG-IMM over them stays above the bound averaged over
    the draws in every state, within the Monte Carlo's 95 % interval."""
    from hyper_nav_filter.core.target_tracking import augmented as au
    from hyper_nav_repro.seed002 import bounds
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_sim.core.tracking_setup import initial_truth, scenario_track, tracker_config
    sc = load_scenario(repro_seed002.SCENARIOS[1])
    cfg = tracker_config(sc)
    setup = au.AugmentedSetup.from_dict(sc.data["tracker_augmented"])
    track = scenario_track(sc)
    t = np.concatenate([[0.0], track.t_s])
    x = np.vstack([initial_truth(sc)[None], track.x])
    n = int(np.searchsorted(t, 300.0, side="right"))
    par = au.equivalent_params(cfg.model, t, x)[:n]
    high = au.maneuver_steps(par, 1.0, setup.maneuver_rate_per_s)
    res = bounds.walk_draws(cfg, setup, t[:n], x[0], par, high, 20, np.random.default_rng(40))
    assert np.all(np.asarray(res["ci95"][1]) >= 1.0), res
