"""Seed 000 reproduction (Yang et al., IEEE Access 2022, RL-DLAC): Table 5 and
the navigation errors of Figs. 10-11, with what the data can tell first.

    ros2run hyper_nav_repro repro_seed000 [--short] [--seeds 10] [--out DIR]

1. Bound: the Cramer-Rao bound of the three natural frequencies from one
   re-estimation window (``core.lever_arm.crb``, on the mean of the data) for
   the paper's flight and for the variants that could help (longer window,
   carrier-phase-grade fixes, better GNSS velocity, modal excitation).
2. Reward surface around the truth: the environment's reward (minus the
   position error) and the innovations' log-likelihood along each frequency.
3. Table 5 over ``--seeds`` random seeds of ``seed000_rl_dlac``: the Table 2
   filter flies, the node's monitor (``core.lever_arm.monitor``) fires on the
   position residual, DDPG (Table 3) re-estimates on the window; learned
   frequencies, errors, mean and spread, beside the paper's.
4. Identifiers on the same windows and budget: DDPG, CMA-ES, Nelder-Mead,
   maximum likelihood on the innovations (error, wall time), on the paper's
   flight and where the bound allows (modal excitation, model-consistent data).
5. Navigation errors over the flight: KF-FLAC (rigid lever arm r0, no modes),
   the elastic model with Table 2 frequencies, and RL-DLAC (learned frequencies
   from the update epoch on, through the fusion engine's model updates).
6. The identifier on the simulator's own data (issue 24): excited flight
   (first two doublets, 4.5 s) with carrier-phase-grade fixes, the paper's Table 4 and two
   other true frequency sets x ``--ident-seeds`` seeds, the filter's model at
   +8 / -10 / +12 %: maximum likelihood (its Fisher sigma; converged only
   off the box edge) and DDPG on the same windows; the fraction with all
   three frequencies within 3 reported sigma and the RMS of error / sigma.

Prints the tables, writes ``seed000_rl_dlac.json`` and PNGs (reward per
episode, frequency estimates, navigation errors, reward surface) to ``--out``.
``--short`` runs every part on a 12 s flight with 2 s windows (the test).
"""
from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import pathlib
import sys
import time

import numpy as np

from hyper_nav_filter.core.elastic_lever_arm import TABLE2_FREQ_RADPS, TABLE4_FREQ_RADPS
from hyper_nav_sim.core.scenario import load_scenario

from hyper_nav_aiding.lever_arm.core import identifiers
from hyper_nav_aiding.lever_arm.core.config import LeverArmLearningConfig
from hyper_nav_aiding.lever_arm.core.crb import fisher_information
from hyper_nav_aiding.lever_arm.core.env import LeverArmFrequencyEnv, position_error_m
from hyper_nav_aiding.lever_arm.core.reestimate import reestimate
from hyper_nav_aiding.lever_arm.core.replay import replay
from .study import navigation_errors
from hyper_nav_aiding.lever_arm.sim_windows import (
    SimulatedFlight, model_consistent_window, triggered_window, with_gnss_sigmas,
)

PAPER = {"initial_radps": list(TABLE2_FREQ_RADPS), "true_radps": list(TABLE4_FREQ_RADPS),
         "learned_radps": [20.1389, 55.1664, 113.5816], "error_pct": [0.13, 0.35, 0.46], "mean_error_pct": 0.31}
CARRIER_PHASE = (0.02, 0.005)          # m, m/s per axis: carrier-phase-grade fixes (our figures)
# the data each comparison case rests on, printed in the same row as its figures (issue 24)
DATA = {"paper": "simulator world (RK4 modes, noisy IMU), paper's flight, the scenario's fixes",
        "excited": "perfect-model data (fixes on the filter's own prediction), doublets, carrier-phase-grade fixes",
        "excited_world": "simulator world (RK4 modes, noisy IMU), doublets, carrier-phase-grade fixes",
        "identifier": "simulator world (RK4 modes on the continuous load, noisy IMU, 400 Hz load sensor with its "
                      "own noise), excited (first two doublets), carrier-phase-grade fixes"}
# true frequency sets of the identifier study (part 6): the paper's Table 4, issue 24's unseen set, one more
IDENT_SETS = {"paper Table 4": tuple(TABLE4_FREQ_RADPS), "issue 24": (19.2, 58.7, 107.5),
              "other": (22.0, 52.0, 104.0)}
IDENT_GUESS = (1.08, 0.90, 1.12)        # the filter's model: the initial guesses (+8 / -10 / +12 %)


@dataclasses.dataclass(frozen=True)
class Setup:
    scenario: str = "seed000_rl_dlac"
    excited: str = "seed000_rl_dlac_excited"
    overrides: tuple = ()              # (dotted field, value) applied to both scenarios
    monitor_from_s: float = 160.0      # the drift reaches Table 4 at 150 s in seed000_rl_dlac
    bound_window_end_s: float = 170.0  # the CRB/surface windows end here (the doublets are at 161-167 s)
    long_window_s: float = 60.0
    window_s: float | None = None      # None: the scenario block's
    episodes: int | None = None
    surface_fracs: tuple = (0.8, 0.9, 0.95, 0.98, 1.0, 1.02, 1.05, 1.1, 1.2)
    surface_data: tuple = ("noisy", "mean")
    nav_duration_s: float | None = None
    all_bound_cases: bool = True
    ident_window: tuple = (160.8, 4.5)  # part 6: (start s, length s) of the window over the first two doublets
    ident_sets: tuple = tuple(IDENT_SETS)
    ident_ml_budget: int = 900          # maximum likelihood's own pass budget (sweeps + 3 starts)


SHORT = Setup(overrides=(("duration_s", 5.0), ("lever_arm.freq_drift_time_s", 0.0),
                         ("lever_arm_learning.trigger.averaging_s", 0.3),
                         ("lever_arm_learning.trigger.threshold_m", 1.0),
                         ("lever_arm_learning.trigger.release_m", 0.5)),
              monitor_from_s=2.5, bound_window_end_s=2.5, long_window_s=2.0, window_s=1.0, episodes=2,
              surface_fracs=(0.95, 1.0, 1.05), surface_data=("noisy",), nav_duration_s=5.0, all_bound_cases=False,
              ident_window=(2.0, 1.0), ident_sets=("paper Table 4",), ident_ml_budget=60)


def _scenario(name: str, seed: int, setup: Setup):
    sc = load_scenario(name)
    sc.data = copy.deepcopy(sc.data)
    sc.data["seed"] = int(seed)
    for dotted, value in setup.overrides:
        cur = sc.data
        parts = dotted.split(".")
        for p in parts[:-1]:
            cur = cur[p]
        cur[parts[-1]] = value
    if setup.window_s is not None:
        sc.data["lever_arm_learning"]["window_s"] = setup.window_s
    if setup.episodes is not None:
        sc.data["lever_arm_learning"]["agent"]["episodes"] = setup.episodes
        sc.data["lever_arm_learning"]["budget_passes"] = setup.episodes * 5 + 1
    return sc


def _learning(sc) -> LeverArmLearningConfig:
    return LeverArmLearningConfig.from_block(sc.data["lever_arm_learning"])


def _err_pct(w, truth) -> list:
    return (100.0 * (np.asarray(w) - truth) / truth).tolist()


# ---- 1. bound -----------------------------------------------------------------------------
def bound_table(setup: Setup, log) -> dict:
    """CRB of the frequencies from one window (mean data) for the paper's setup and
    the variants; windows end at ``setup.bound_window_end_s``."""
    sc = _scenario(setup.scenario, 0, setup)
    lc = _learning(sc)
    cfg = sc.filter_config()
    t1, T, TL = setup.bound_window_end_s, lc.window_s, setup.long_window_s
    truth = np.asarray(sc.data["lever_arm"]["natural_freq_final_radps"], float)
    out = {"window_end_s": t1, "truth_radps": truth.tolist(), "cases": []}
    mean = SimulatedFlight.from_scenario(sc, noise_free=True)
    (s_short, P_short), (s_long, P_long) = mean.fused_states_at(cfg, [t1 - T, t1 - TL])
    w_short, w_long = mean.window(s_short, P_short, T), mean.window(s_long, P_long, TL)
    pos, vel = sc["gnss.pos_sigma_enu_m"][0], sc["gnss.vel_sigma_enu_mps"][0]
    cases = [(f"paper: {T:g} s window, fixes {pos:g} m / {vel:g} m/s", w_short),
             (f"{TL:g} s window", w_long),
             (f"carrier-phase fixes {CARRIER_PHASE[0]:g} m / {CARRIER_PHASE[1]:g} m/s, {T:g} s",
              with_gnss_sigmas(w_short, *CARRIER_PHASE)),
             (f"carrier-phase fixes, {TL:g} s", with_gnss_sigmas(w_long, *CARRIER_PHASE)),
             (f"GNSS velocity 0.01 m/s, {T:g} s", with_gnss_sigmas(w_short, pos, 0.01))]
    if not setup.all_bound_cases:
        cases = cases[:3:2]
    sce = _scenario(setup.excited, 0, setup)
    ex = SimulatedFlight.from_scenario(sce, noise_free=True)
    s_ex, P_ex = ex.fused_state_at(cfg, t1 - T)
    w_ex = model_consistent_window(ex.window(s_ex, P_ex, T), cfg, truth)
    cases += [(f"doublets (seed000_rl_dlac_excited), {T:g} s, model-consistent data", w_ex),
              ("doublets + carrier-phase fixes, model-consistent data (part 4's windows)",
               with_gnss_sigmas(w_ex, *CARRIER_PHASE))][:2 if setup.all_bound_cases else 1]
    for name, w in cases:
        t0 = time.perf_counter()
        c = fisher_information(w, cfg, truth)
        d = c.as_dict()
        d["case"] = name
        d["wall_s"] = time.perf_counter() - t0
        out["cases"].append(d)
        log(f"  {name:62s} {_fmt3(d['sigma_pct'])}  best-determined combination {d['principal_sigma_pct'][0]:9.3g} %")
    noisy = SimulatedFlight.from_scenario(sc)
    s_n, P_n = noisy.fused_state_at(cfg, t1 - T)
    c = fisher_information(noisy.window(s_n, P_n, T), cfg, truth).as_dict()
    c["case"] = "paper, observed data (IMU noise driving the filter's modes counted as information)"
    out["observed_data_paper"] = c
    log(f"  {'(observed noisy data, paper case: not a bound, see README)':62s} {_fmt3(c['sigma_pct'])}")
    return out


def _fmt3(v) -> str:
    return " ".join(f"{x:10.3g} %" for x in v)


# ---- 2. reward surface --------------------------------------------------------------------
def _surface(window, cfg, truth, fracs, reward_kind) -> dict:
    """Reward (minus the position error) and innovation negative log-likelihood
    of the window replayed with each frequency in turn scaled by ``fracs``."""
    rows = {}
    for i in range(3):
        rew, nll = [], []
        for f in fracs:
            th = truth.copy()
            th[i] *= f
            p = replay(window, cfg, th)
            rew.append(-position_error_m(p, reward_kind))
            nll.append(p.neg_log_likelihood())
        rows[f"w{i + 1}"] = {"reward_m": rew, "nll": nll}
    return rows


def reward_surface(setup: Setup, log) -> dict:
    sc = _scenario(setup.scenario, 0, setup)
    lc = _learning(sc)
    cfg = sc.filter_config()
    truth = np.asarray(sc.data["lever_arm"]["natural_freq_final_radps"], float)
    t1, T = setup.bound_window_end_s, lc.window_s
    out = {"fractions": list(setup.surface_fracs), "truth_radps": truth.tolist()}
    for label, noise_free in [x for x in (("noisy", False), ("mean", True)) if x[0] in setup.surface_data]:
        fl = SimulatedFlight.from_scenario(sc, noise_free=noise_free)
        s, P = fl.fused_state_at(cfg, t1 - T)
        w = fl.window(s, P, T)
        rows = _surface(w, cfg, truth, setup.surface_fracs, lc.reestimation.env.reward_kind)
        for i in range(3):
            r, n = np.array(rows[f"w{i + 1}"]["reward_m"]), np.array(rows[f"w{i + 1}"]["nll"])
            log(f"  {label:5s} w{i + 1}: reward spread {1e3 * np.ptp(r):8.3f} mm (reward {r.mean():8.3f} m, "
                f"max at x{setup.surface_fracs[int(np.argmax(r))]:.2f}); log-likelihood spread {np.ptp(n):8.3f} "
                f"(max at x{setup.surface_fracs[int(np.argmin(n))]:.2f})")
        out[label] = rows
    # the excited flight's own (simulated, not model-consistent) data: is the truth the optimum?
    sce = _scenario(setup.excited, 0, setup)
    fl = SimulatedFlight.from_scenario(sce)
    s, P = fl.fused_state_at(cfg, t1 - T)
    w = fl.window(s, P, T)
    rows = _surface(w, cfg, truth, setup.surface_fracs, lc.reestimation.env.reward_kind)
    for i in range(3):
        r, n = np.array(rows[f"w{i + 1}"]["reward_m"]), np.array(rows[f"w{i + 1}"]["nll"])
        log(f"  excited flight, simulated data, w{i + 1}: reward max at x{setup.surface_fracs[int(np.argmax(r))]:.2f} "
            f"({1e3 * (r.max() - r[setup.surface_fracs.index(1.0)]):.3f} mm above the truth's); log-likelihood max "
            f"at x{setup.surface_fracs[int(np.argmin(n))]:.2f} ({n[setup.surface_fracs.index(1.0)] - n.min():.1f} "
            f"above the truth's)")
    out["excited_simulated"] = rows
    return out


# ---- 3. Table 5 over seeds ----------------------------------------------------------------
def table5_run(job):
    """One campaign run of Table 5: (setup, seed) -> the run, or None when the trigger did not fire."""
    setup, seed = job
    sc = _scenario(setup.scenario, seed, setup)
    lc = _learning(sc)
    cfg = sc.filter_config()
    truth = np.asarray(sc.data["lever_arm"]["natural_freq_final_radps"], float)
    fl = SimulatedFlight.from_scenario(sc)
    window, t_fire, mon = triggered_window(fl, cfg, lc, setup.monitor_from_s)
    if window is None:
        return None
    truth_w = fl.true_frequencies(window.t0_s, window.t_end_s)
    rc = dataclasses.replace(lc.reestimation, seed=int(seed), timeout_s=3600.0)
    res = reestimate(window, cfg, cfg.lever_arm_natural_freq_radps, rc)
    return {"seed": int(seed), "t_trigger_s": t_fire, "window_s": [window.t0_s, window.t_end_s],
            "trigger_statistic_m": mon.trigger.statistic_m, "truth_window_radps": truth_w.tolist(),
            "learned_radps": res.freqs_radps.tolist(), "error_pct": _err_pct(res.freqs_radps, truth),
            "reward_initial_m": res.reward_initial, "reward_m": res.reward, "accepted": res.accepted,
            "reason": res.reason, "episode_rewards_m": res.episode_rewards, "n_passes": res.n_passes,
            "wall_s": res.wall_s, "cpu_s": res.cpu_s, "sigma_crb_radps": None if res.sigma_radps is None else
            np.asarray(res.sigma_radps).tolist(), "history": res.history,
            "_window": window, "_cfg": cfg, "_truth": truth, "_rc": rc}


def _run_json(r):
    return None if r is None else {k: v for k, v in r.items() if not k.startswith("_")}


def table5(setup: Setup, seeds, log, opts=None, out_dir=None) -> dict:
    """Table 5 over seeds: every seed a run of the campaign engine (``hyper_nav_workbench.campaign``, ``opts``)."""
    from hyper_nav_workbench import campaign
    seeds = list(seeds)
    done = campaign.run("repro_seed000", table5_run, [(setup, s) for s in seeds],
                        keys=[f"table5_seed{s:03d}" for s in seeds], opts=opts or campaign.Options(),
                        out_dir=out_dir, to_json=_run_json, warm_up=("hyper_nav_repro.seed000.reproduce",)).results
    runs = []
    for seed, r in zip(seeds, done):
        if r is None:
            log(f"  seed {seed}: the trigger did not fire")
            continue
        runs.append(r)
        log(f"  seed {seed}: trigger at {r['t_trigger_s']:.1f} s; learned {_fmt_w(r['learned_radps'])} error "
            f"{_fmt_pct(r['error_pct'])}; reward {r['reward_initial_m']:.4f} -> {r['reward_m']:.4f} m; "
            f"{r['n_passes']} passes {r['wall_s']:.1f} s wall {r['cpu_s']:.1f} s CPU")
    errs = np.abs([r["error_pct"] for r in runs])
    summary = {"mean_abs_error_pct": errs.mean(axis=0).tolist(), "std_abs_error_pct": errs.std(axis=0).tolist(),
               "mean_of_mean_error_pct": float(errs.mean()), "std_of_mean_error_pct": float(errs.mean(axis=1).std()),
               "learned_mean_radps": np.mean([r["learned_radps"] for r in runs], axis=0).tolist(),
               "learned_std_radps": np.std([r["learned_radps"] for r in runs], axis=0).tolist(),
               "wall_s_mean": float(np.mean([r["wall_s"] for r in runs])),
               "cpu_s_mean": float(np.mean([r["cpu_s"] for r in runs])), "n_seeds": len(runs)}
    return {"runs": runs, "summary": summary}


def _fmt_w(w) -> str:
    return "/".join(f"{x:.4f}" for x in w)


def _fmt_pct(e) -> str:
    return "/".join(f"{x:+.2f}" for x in e) + " %"


# ---- 4. identifiers -----------------------------------------------------------------------
def compare(runs_by_case: dict, log) -> dict:
    """Each method on the same windows and budget as DDPG (``runs_by_case``:
    case -> list of Table-5-style runs with their windows)."""
    out = {}
    for case, runs in runs_by_case.items():
        rows = {m: [] for m in ("ddpg", "cmaes", "nelder_mead", "max_likelihood")}
        for r in runs:
            rows["ddpg"].append({"seed": r["seed"], "freqs_radps": r["learned_radps"], "error_pct": r["error_pct"],
                                 "wall_s": r["wall_s"], "cpu_s": r["cpu_s"], "n_passes": r["n_passes"],
                                 "reward_m": r["reward_m"]})
            budget = r["_rc"].budget_passes - 1
            for m in ("cmaes", "nelder_mead", "max_likelihood"):
                env = LeverArmFrequencyEnv(r["_window"], r["_cfg"], r["_cfg"].lever_arm_natural_freq_radps,
                                           r["_rc"].env)
                fn = {"cmaes": lambda e: identifiers.cmaes(e, budget, seed=r["seed"]),
                      "nelder_mead": lambda e: identifiers.nelder_mead(e, budget),
                      "max_likelihood": lambda e: identifiers.max_likelihood(e, budget)}[m]
                res = fn(env)
                rows[m].append({"seed": r["seed"], "freqs_radps": res.freqs_radps.tolist(),
                                "error_pct": _err_pct(res.freqs_radps, r["_truth"]), "wall_s": res.wall_s,
                                "cpu_s": res.cpu_s, "n_passes": res.n_passes, "reward_m": res.reward, "note": res.note,
                                "sigma_radps": None if res.sigma_radps is None else res.sigma_radps.tolist()})
        summ = {}
        for m, rs in rows.items():
            e = np.abs([x["error_pct"] for x in rs])
            summ[m] = {"mean_abs_error_pct": e.mean(axis=0).tolist(), "mean_error_pct": float(e.mean()),
                       "std_of_mean_error_pct": float(e.mean(axis=1).std()),
                       "wall_s_mean": float(np.mean([x["wall_s"] for x in rs])),
                       "cpu_s_mean": float(np.mean([x["cpu_s"] for x in rs])),
                       "passes_mean": float(np.mean([x["n_passes"] for x in rs])), "data": DATA.get(case, case)}
            sig = [x for x in rs if x.get("sigma_radps") is not None]
            within = ""
            if sig:
                truth = runs[0]["_truth"]
                ok = [bool(np.all(np.abs(np.array(x["freqs_radps"]) - truth) < 3.0 * np.array(x["sigma_radps"])))
                      for x in sig]
                conv = [str(x.get("note", "")).startswith("converged") for x in sig]
                summ[m]["fraction_within_3_reported_sigma"] = float(np.mean(ok))
                summ[m]["fraction_converged"] = float(np.mean(conv))
                within = (f", within 3 reported sigma in {sum(ok)}/{len(ok)} (converged in {sum(conv)}/{len(conv)}; "
                          "an unconverged sigma is not a bound)")
            log(f"  {case:13s} {m:15s} |error| {_fmt_pct(summ[m]['mean_abs_error_pct'])} mean "
                f"{summ[m]['mean_error_pct']:8.3f} % (+- {summ[m]['std_of_mean_error_pct']:.3f}) "
                f"wall {summ[m]['wall_s_mean']:6.1f} s, CPU {summ[m]['cpu_s_mean']:6.1f} s, "
                f"{summ[m]['passes_mean']:.0f} passes{within}; data: {DATA.get(case, case)}")
        out[case] = {"runs": rows, "summary": summ, "data": DATA.get(case, case)}
    return out


def excited_run(job) -> dict:
    """One campaign run of the excited comparison: (setup, seed) -> the run."""
    setup, seed = job
    sc = _scenario(setup.excited, seed, setup)
    lc = _learning(sc)
    cfg = sc.filter_config()
    truth = np.asarray(sc.data["lever_arm"]["natural_freq_final_radps"], float)
    fl = SimulatedFlight.from_scenario(sc)
    t1, T = setup.bound_window_end_s, lc.window_s
    s, P = fl.fused_state_at(cfg, t1 - T)
    w = model_consistent_window(with_gnss_sigmas(fl.window(s, P, T), *CARRIER_PHASE), cfg, truth,
                                np.random.default_rng(1000 + seed))
    rc = dataclasses.replace(lc.reestimation, seed=int(seed), timeout_s=3600.0)
    res = reestimate(w, cfg, cfg.lever_arm_natural_freq_radps, rc)
    return {"seed": int(seed), "learned_radps": res.freqs_radps.tolist(),
            "error_pct": _err_pct(res.freqs_radps, truth), "reward_m": res.reward,
            "reward_initial_m": res.reward_initial, "wall_s": res.wall_s, "cpu_s": res.cpu_s,
            "n_passes": res.n_passes,
            "episode_rewards_m": res.episode_rewards, "history": res.history,
            "_window": w, "_cfg": cfg, "_truth": truth, "_rc": rc}


def excited_world_run(job) -> dict:
    """One campaign run on the excited flight's own data (the simulator's
    world, not the perfect-model switch) with carrier-phase-grade fixes:
    (setup, seed) -> the run, DDPG as in Table 5."""
    setup, seed = job
    sc = _scenario(setup.excited, seed, setup)
    sc.data["gnss"]["pos_sigma_enu_m"] = [CARRIER_PHASE[0]] * 3
    sc.data["gnss"]["vel_sigma_enu_mps"] = [CARRIER_PHASE[1]] * 3
    lc = _learning(sc)
    cfg = sc.filter_config()
    truth = np.asarray(sc.data["lever_arm"]["natural_freq_final_radps"], float)
    fl = SimulatedFlight.from_scenario(sc)
    t1, T = setup.bound_window_end_s, lc.window_s
    s, P = fl.fused_state_at(cfg, t1 - T)
    w = fl.window(s, P, T)
    rc = dataclasses.replace(lc.reestimation, seed=int(seed), timeout_s=3600.0)
    res = reestimate(w, cfg, cfg.lever_arm_natural_freq_radps, rc)
    return {"seed": int(seed), "learned_radps": res.freqs_radps.tolist(),
            "error_pct": _err_pct(res.freqs_radps, truth), "reward_m": res.reward,
            "reward_initial_m": res.reward_initial, "wall_s": res.wall_s, "cpu_s": res.cpu_s,
            "n_passes": res.n_passes, "episode_rewards_m": res.episode_rewards, "history": res.history,
            "_window": w, "_cfg": cfg, "_truth": truth, "_rc": rc}


def excited_world_runs(setup: Setup, seeds, log, opts=None, out_dir=None) -> list:
    """``excited_world_run`` over seeds, every seed a campaign run."""
    from hyper_nav_workbench import campaign
    seeds = list(seeds)
    runs = campaign.run("repro_seed000", excited_world_run, [(setup, s) for s in seeds],
                        keys=[f"excited_world_seed{s:03d}" for s in seeds], opts=opts or campaign.Options(),
                        out_dir=out_dir, to_json=_run_json, warm_up=("hyper_nav_repro.seed000.reproduce",)).results
    for r in runs:
        log(f"  excited seed {r['seed']} (simulator world): DDPG {_fmt_w(r['learned_radps'])} "
            f"error {_fmt_pct(r['error_pct'])}")
    return runs


def excited_runs(setup: Setup, seeds, log, opts=None, out_dir=None) -> list:
    """Windows where the bound allows: the excited flight with carrier-phase-
    grade fixes (the paper's r_G), GNSS moved onto the filter's own model at
    the true frequencies plus white noise of those sigmas (the perfect-model
    switch), DDPG as in Table 5; every seed a campaign run."""
    from hyper_nav_workbench import campaign
    seeds = list(seeds)
    runs = campaign.run("repro_seed000", excited_run, [(setup, s) for s in seeds],
                        keys=[f"excited_seed{s:03d}" for s in seeds], opts=opts or campaign.Options(),
                        out_dir=out_dir, to_json=_run_json, warm_up=("hyper_nav_repro.seed000.reproduce",)).results
    for r in runs:
        log(f"  excited seed {r['seed']}: DDPG {_fmt_w(r['learned_radps'])} error {_fmt_pct(r['error_pct'])}")
    return runs


# ---- 6. the identifier on the simulator's own data -----------------------------------------------
def identifier_run(job) -> dict:
    """One window of the identifier study: (setup, true set name, seed) ->
    maximum likelihood (global sweeps + Levenberg-Marquardt, its Fisher sigma)
    and DDPG (Table 3 settings, the scenario's budget) on the same window of
    the excited flight's own data (the simulator's world), carrier-phase-grade
    fixes, true frequencies constant at the set, the filter's model at
    ``IDENT_GUESS`` x truth (both estimators start there; box +-25 %)."""
    setup, name, seed = job
    truth = np.asarray(IDENT_SETS[name], float)
    sc = _scenario(setup.excited, seed, setup)
    t0, T = setup.ident_window
    sc.data["duration_s"] = min(float(sc.data["duration_s"]), t0 + T + 0.5)
    la = sc.data["lever_arm"]
    la["natural_freq_initial_radps"] = la["natural_freq_final_radps"] = truth.tolist()
    sc.data["gnss"]["pos_sigma_enu_m"] = [CARRIER_PHASE[0]] * 3
    sc.data["gnss"]["vel_sigma_enu_mps"] = [CARRIER_PHASE[1]] * 3
    guess = truth * np.asarray(IDENT_GUESS)
    cfg = sc.filter_config().with_updates({"lever_arm_natural_freq_radps": tuple(float(x) for x in guess)})
    lc = _learning(sc)
    fl = SimulatedFlight.from_scenario(sc)
    s, P = fl.fused_state_at(cfg, t0)
    w = fl.window(s, P, T)
    # global stage: three sweeps of 41-point scans per frequency over the whole box, then three starts
    ml = identifiers.max_likelihood(LeverArmFrequencyEnv(w, cfg, guess, lc.reestimation.env), setup.ident_ml_budget,
                                    grid_points=41, sweeps=3, n_starts=3)
    rc = dataclasses.replace(lc.reestimation, seed=int(seed), timeout_s=3600.0)
    dd = reestimate(w, cfg, guess, rc)
    z = (ml.freqs_radps - truth) / ml.sigma_radps
    converged = str(ml.note).startswith("converged")      # an unconverged sigma is not a bound: never counted within
    return {"set": name, "seed": int(seed), "true_radps": truth.tolist(), "guess_radps": guess.tolist(),
            "max_likelihood": {"freqs_radps": ml.freqs_radps.tolist(), "error_pct": _err_pct(ml.freqs_radps, truth),
                               "sigma_radps": ml.sigma_radps.tolist(), "error_over_sigma": z.tolist(),
                               "within_3_sigma": bool(converged and np.all(np.abs(z) < 3.0)), "note": ml.note,
                               "converged": converged, "n_passes": ml.n_passes,
                               "wall_s": ml.wall_s, "cpu_s": ml.cpu_s},
            "ddpg": {"freqs_radps": dd.freqs_radps.tolist(), "error_pct": _err_pct(dd.freqs_radps, truth),
                     "error_over_ml_sigma": ((dd.freqs_radps - truth) / ml.sigma_radps).tolist(),
                     "n_passes": dd.n_passes, "wall_s": dd.wall_s, "cpu_s": dd.cpu_s}}


def identifier_study(setup: Setup, seeds, log, opts=None, out_dir=None) -> dict:
    """``identifier_run`` over the true sets x seeds (campaign runs), with
    the fraction of windows where all three frequencies are within 3 of the
    reported sigma, and the RMS of error / sigma (1 for an honest sigma)."""
    from hyper_nav_workbench import campaign
    jobs = [(setup, name, s) for name in setup.ident_sets for s in seeds]
    runs = campaign.run("repro_seed000", identifier_run, jobs,
                        keys=[f"identifier_{name.replace(' ', '_')}_seed{s:03d}" for _, name, s in jobs],
                        opts=opts or campaign.Options(), out_dir=out_dir,
                        warm_up=("hyper_nav_repro.seed000.reproduce",)).results
    by_set = {}
    for name in setup.ident_sets:
        rs = [r for r in runs if r["set"] == name]
        ml = [r["max_likelihood"] for r in rs]
        dd = [r["ddpg"] for r in rs]
        z = np.array([m["error_over_sigma"] for m in ml])
        by_set[name] = {
            "true_radps": rs[0]["true_radps"], "n": len(rs), "data": DATA["identifier"],
            "ml_all_three_within_3_sigma": int(sum(m["within_3_sigma"] for m in ml)),
            "ml_within_3_sigma_per_freq": np.sum((np.abs(z) < 3.0) & np.array([[m["converged"]] for m in ml]),
                                                 axis=0).tolist(),
            "ml_converged": int(sum(m["converged"] for m in ml)),
            "ml_error_over_sigma_rms": np.sqrt(np.mean(z**2, axis=0)).tolist(),
            "ml_mean_abs_error_pct": np.mean(np.abs([m["error_pct"] for m in ml]), axis=0).tolist(),
            "ml_mean_sigma_pct": np.mean([100.0 * np.array(m["sigma_radps"]) / rs[0]["true_radps"] for m in ml],
                                         axis=0).tolist(),
            "ml_wall_s_mean": float(np.mean([m["wall_s"] for m in ml])),
            "ml_wall_s_max": float(np.max([m["wall_s"] for m in ml])),
            "ml_passes_mean": float(np.mean([m["n_passes"] for m in ml])),
            "ddpg_mean_abs_error_pct": np.mean(np.abs([d["error_pct"] for d in dd]), axis=0).tolist(),
            "ddpg_all_three_within_3_ml_sigma": int(sum(bool(np.all(np.abs(d["error_over_ml_sigma"]) < 3.0))
                                                        for d in dd)),
            "ddpg_wall_s_mean": float(np.mean([d["wall_s"] for d in dd])),
            "ddpg_passes_mean": float(np.mean([d["n_passes"] for d in dd]))}
        b = by_set[name]
        log(f"  {name:14s} true {_fmt_w(b['true_radps'])}, {b['n']} seeds; data: {b['data']}")
        log(f"    max likelihood: all three within 3 reported sigma {b['ml_all_three_within_3_sigma']}/{b['n']} "
            f"(per frequency {b['ml_within_3_sigma_per_freq']}), converged {b['ml_converged']}/{b['n']}, "
            f"|error| {_fmt_pct(b['ml_mean_abs_error_pct'])}, sigma {_fmt_pct(b['ml_mean_sigma_pct'])}, "
            f"RMS error/sigma {np.round(b['ml_error_over_sigma_rms'], 2).tolist()}, "
            f"wall {b['ml_wall_s_mean']:.1f} s (max {b['ml_wall_s_max']:.1f}), {b['ml_passes_mean']:.0f} passes")
        log(f"    DDPG:           |error| {_fmt_pct(b['ddpg_mean_abs_error_pct'])}, all three within 3 ML sigma "
            f"{b['ddpg_all_three_within_3_ml_sigma']}/{b['n']}, wall {b['ddpg_wall_s_mean']:.1f} s, "
            f"{b['ddpg_passes_mean']:.0f} passes")
    n = len(runs)
    n_ok = sum(r["max_likelihood"]["within_3_sigma"] for r in runs)
    log(f"  all sets: max likelihood all three within 3 reported sigma in {n_ok}/{n} windows "
        f"({100.0 * n_ok / max(n, 1):.0f} %; goal >= 90 %)")
    return {"by_set": by_set, "runs": runs, "all_three_within_3_sigma": int(n_ok), "n": n,
            "data": DATA["identifier"], "guess_factor": list(IDENT_GUESS), "window": list(setup.ident_window)}


# ---- output ---------------------------------------------------------------------------------
def _public(x):
    if isinstance(x, dict):
        return {k: _public(v) for k, v in x.items() if not str(k).startswith("_")}
    if isinstance(x, (list, tuple)):
        return [_public(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


def print_table5(t5: dict, log) -> None:
    s = t5["summary"]
    log("\nTable 5: natural frequencies (rad/s); ours = mean +- std over "
        f"{s['n_seeds']} seeds (DDPG, Table 3 settings); data: {DATA['paper']}")
    log(f"  {'':4s} {'initial':>9s} {'true':>9s} {'paper':>9s} {'err':>6s} | {'ours':>9s} {'+-':>7s} "
        f"{'|err| mean':>10s} {'+-':>7s}")
    for i in range(3):
        log(f"  w{i + 1}   {PAPER['initial_radps'][i]:9.4f} {PAPER['true_radps'][i]:9.4f} "
            f"{PAPER['learned_radps'][i]:9.4f} {PAPER['error_pct'][i]:5.2f}% | {s['learned_mean_radps'][i]:9.4f} "
            f"{s['learned_std_radps'][i]:7.4f} {s['mean_abs_error_pct'][i]:9.2f}% {s['std_abs_error_pct'][i]:6.2f}%")
    log(f"  mean error: paper {PAPER['mean_error_pct']:.2f} %, ours {s['mean_of_mean_error_pct']:.2f} % "
        f"(+- {s['std_of_mean_error_pct']:.2f} % over seeds); one re-estimation {s['wall_s_mean']:.1f} s wall, "
        f"{s['cpu_s_mean']:.1f} s CPU")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--short", action="store_true", help="every part on a 12 s flight, 2 s windows (test)")
    ap.add_argument("--seeds", type=int, default=10, help="random seeds for Table 5")
    ap.add_argument("--compare-seeds", type=int, default=3, help="seeds for the identifier comparison")
    ap.add_argument("--out", default="results/seed000_rl_dlac", help="output directory (JSON, PNGs)")
    ap.add_argument("--ident-seeds", type=int, default=10, help="seeds per true set of the identifier study (6)")
    ap.add_argument("--parts", default="1,2,3,4,5,6", help="parts to run (comma-separated; 4 and 5 need 3); "
                    "results of parts not run are kept from an existing JSON in --out")
    from hyper_nav_workbench import campaign
    campaign.add_arguments(ap)             # --workers, --scheduler, --max-workers: the seeds as a dask campaign
    args = ap.parse_args(argv)
    opts = campaign.options(args)
    setup = SHORT if args.short else Setup()
    n_seeds = 1 if args.short else args.seeds
    n_cmp = 1 if args.short else min(args.compare_seeds, n_seeds)
    out_dir = pathlib.Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()

    def log(msg=""):
        print(msg, flush=True)

    parts = {int(x) for x in args.parts.split(",")}
    if parts & {4, 5} and 3 not in parts:
        ap.error("parts 4 and 5 need part 3")
    json_path = out_dir / "seed000_rl_dlac.json"
    result = json.loads(json_path.read_text()) if json_path.exists() and parts != {1, 2, 3, 4, 5, 6} else {}
    result.update({"paper": PAPER, "setup": _public(dataclasses.asdict(setup))})
    if 1 in parts:
        log("1. Cramer-Rao bound of (w1, w2, w3) from one window, 1-sigma relative (mean data):")
        result["bound"] = bound_table(setup, log)
    if 2 in parts:
        log("\n2. Reward surface around the truth (one frequency varied, others true):")
        result["surface"] = reward_surface(setup, log)
    if 3 in parts:
        log(f"\n3. Table 5 over {n_seeds} seeds ({setup.scenario}):")
        t5 = table5(setup, range(n_seeds), log, opts, out_dir / "runs")
        result["table5"] = t5
        print_table5(t5, log)
    if 4 in parts:
        log(f"\n4. Identifiers on the same windows and budget ({n_cmp} seeds):")
        ex = excited_runs(setup, range(n_cmp), log, opts, out_dir / "runs")
        exw = excited_world_runs(setup, range(n_cmp), log, opts, out_dir / "runs")
        result["compare"] = compare({"paper": t5["runs"][:n_cmp], "excited": ex, "excited_world": exw}, log)
    if 5 in parts:
        log("\n5. Navigation errors over the flight (Figs. 10-11):")
        run0 = t5["runs"][0]
        sc0 = _scenario(setup.scenario, run0["seed"], setup)
        result["navigation"] = navigation_errors(sc0, _learning(sc0), run0, log, setup.nav_duration_s)
    if 6 in parts:
        n_id = 1 if args.short else args.ident_seeds
        log(f"\n6. The identifier on the simulator's own data, excited + carrier-phase-grade, "
            f"{len(setup.ident_sets)} true sets x {n_id} seeds (maximum likelihood; DDPG beside it):")
        result["identifier"] = identifier_study(setup, range(n_id), log, opts, out_dir / "runs")
    result["wall_s"] = time.perf_counter() - t_start
    result = _public(result)
    json_path.write_text(json.dumps(result, indent=1))
    from .plots import write_plots
    pngs = write_plots(result, out_dir)
    log(f"\nwrote {out_dir / 'seed000_rl_dlac.json'} and {', '.join(p.name for p in pngs)} "
        f"({result['wall_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
