"""One re-estimation of the natural frequencies from a data window: the job
the node's worker process runs (pure function of picklable inputs).

It builds the environment around the window with the model in force as the
initial state, runs the configured method (``ddpg``, the paper's; or a
classical identifier from ``identifiers``) within ``budget_passes`` filter
passes and ``timeout_s``, and accepts the estimate only if it improves the
reward of the model in force by more than ``min_improvement_m``; the
estimate's 1-sigma comes from the Cramer-Rao bound at the estimate (``crb``,
7 more passes) unless the method provides it.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from hyper_nav_aiding.lever_arm.core import identifiers
from hyper_nav_aiding.lever_arm.core.ddpg import DDPGConfig
from hyper_nav_aiding.lever_arm.core.crb import fisher_information
from hyper_nav_aiding.lever_arm.core.env import DeadlineExceeded, EnvConfig, LeverArmFrequencyEnv

METHODS = ("ddpg", "cmaes", "nelder_mead", "max_likelihood")


@dataclass(frozen=True)
class ReestimationConfig:
    method: str = "ddpg"
    env: EnvConfig = EnvConfig()
    agent: DDPGConfig = DDPGConfig()
    budget_passes: int = 250              # Table 3: 50 episodes x 5 steps
    min_improvement_m: float = 0.0
    sigma_from_crb: bool = True
    seed: int = 0
    timeout_s: float = 60.0

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        if self.budget_passes < 8:
            raise ValueError("budget_passes must be >= 8")
        if not self.timeout_s > 0:
            raise ValueError("timeout_s must be > 0")


@dataclass
class ReestimationResult:
    accepted: bool
    reason: str
    method: str
    initial_freqs_radps: np.ndarray
    freqs_radps: np.ndarray
    sigma_radps: np.ndarray | None
    reward_initial: float
    reward: float
    n_passes: int
    wall_s: float
    episode_rewards: list = field(default_factory=list)
    history: list = field(default_factory=list)          # (frequencies, reward) of every pass
    cpu_s: float = 0.0                                    # process CPU time of the job

    def note(self) -> str:
        return (f"{self.method}: reward {self.reward_initial:.4f} -> {self.reward:.4f} m, "
                f"{self.n_passes} passes, {self.wall_s:.1f} s wall, {self.cpu_s:.1f} s CPU")


def reestimate(window, filter_cfg, current_freqs_radps, rc: ReestimationConfig,
               reference_freqs_radps=None) -> ReestimationResult:
    t0, c0 = time.perf_counter(), time.process_time()
    deadline = time.monotonic() + rc.timeout_s
    window.check()
    w0 = np.asarray(current_freqs_radps, float)
    env = LeverArmFrequencyEnv(window, filter_cfg, w0, rc.env, reference_freqs_radps)
    env.deadline_s = deadline
    freqs, reward, sigma, ep_rewards, timed_out = w0, -np.inf, None, [], False
    try:
        if rc.method == "ddpg":
            from hyper_nav_aiding.lever_arm.core import ddpg
            n_ep = max(1, min(rc.agent.episodes, (rc.budget_passes - 1) // rc.agent.steps))
            res = ddpg.train(env, dataclasses.replace(rc.agent, episodes=n_ep), seed=rc.seed)
            freqs, reward, ep_rewards = res.freqs_radps, res.reward, res.episode_rewards
        else:
            r = {"cmaes": lambda: identifiers.cmaes(env, rc.budget_passes - 1, seed=rc.seed),
                 "nelder_mead": lambda: identifiers.nelder_mead(env, rc.budget_passes - 1),
                 "max_likelihood": lambda: identifiers.max_likelihood(env, rc.budget_passes - 1)}[rc.method]()
            freqs, reward, sigma = r.freqs_radps, r.reward, r.sigma_radps
    except DeadlineExceeded:
        timed_out = True
        freqs, reward = env.best_freqs_radps, env.best_reward
    env.deadline_s = None
    reward_initial = next((rw for w, rw in env.history if np.array_equal(w, w0)), None)
    if reward_initial is None:
        reward_initial = float("nan") if timed_out else env.evaluate(w0)
    if sigma is None and rc.sigma_from_crb and not timed_out and time.monotonic() < deadline:
        sigma = fisher_information(window, filter_cfg, freqs).sigma_radps
        env.n_passes += 7
    improvement = reward - reward_initial
    if timed_out:
        accepted, reason = False, f"timed out after {time.perf_counter() - t0:.1f} s (limit {rc.timeout_s} s)"
    elif not np.all(np.isfinite(freqs)) or not np.isfinite(reward):
        accepted, reason = False, "non-finite estimate"
    elif improvement <= rc.min_improvement_m:
        accepted, reason = False, f"no improvement ({improvement:.2e} m <= {rc.min_improvement_m} m)"
    else:
        accepted, reason = True, f"improved by {improvement:.2e} m"
    return ReestimationResult(accepted, reason, rc.method, w0, np.asarray(freqs, float), sigma, reward_initial,
                              reward, env.n_passes, time.perf_counter() - t0, ep_rewards,
                              [(w.tolist(), r) for w, r in env.history], time.process_time() - c0)
