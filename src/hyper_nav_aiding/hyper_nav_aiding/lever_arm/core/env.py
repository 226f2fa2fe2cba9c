"""Gymnasium environment of RL-DLAC (seed 000 section III.B, Table 1).

State: the natural frequencies [w1 w2 w3] of the dynamic lever-arm model,
observed relative to the reference model, x = (w / w_ref - 1) / max_rel, in
[-1, 1]. Action: the change of each frequency, a in [-1, 1]^3 (the actor's tanh
output), applied as w <- w + a * action_scale * w_ref and kept within
w_ref (1 +- max_rel). Environment: the GNSS/INS filter replayed over the data
window with the new frequencies (``replay``). Reward (III.B.3): minus the
position error of that pass, r = -|r_hat - r_G| (m): with ``reward_kind``
"final" the error at the window's last fix (the paper's "final localization
error"), with "rms" the RMS over the window's fixes (our default: the same
quantity with the fix noise averaged). An episode starts from the initial
frequencies and lasts ``max_steps`` steps (Table 3: 5).

Every step costs one filter pass; the environment counts them and keeps the
best state seen (the learned optimum of section III.B).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

from hyper_nav_aiding.lever_arm.core.replay import WindowPass, replay

REWARD_KINDS = ("rms", "final")


class DeadlineExceeded(RuntimeError):
    """A pass was asked for after the environment's deadline (wall clock)."""


def position_error_m(p: WindowPass, reward_kind: str) -> float:
    """|r_hat - r_G| of a pass: RMS over its position fixes or the last one (m)."""
    nu = p.kinds["gnss_pos"].nu
    if reward_kind == "final":
        return float(np.linalg.norm(nu[-1]))
    return float(np.sqrt(np.mean(np.sum(nu**2, axis=1))))


@dataclass(frozen=True)
class EnvConfig:
    max_rel: float = 0.25            # search box: w_ref (1 +- max_rel)
    action_scale: float = 0.05       # largest change per step, relative to w_ref
    max_steps: int = 5               # Table 3, max_episodes_steps
    reward_kind: str = "rms"

    def __post_init__(self):
        if not 0 < self.max_rel < 1:
            raise ValueError(f"max_rel must be in (0, 1), got {self.max_rel}")
        if not 0 < self.action_scale <= self.max_rel:
            raise ValueError(f"action_scale must be in (0, max_rel], got {self.action_scale}")
        if self.max_steps < 1:
            raise ValueError("max_steps must be >= 1")
        if self.reward_kind not in REWARD_KINDS:
            raise ValueError(f"reward_kind must be one of {REWARD_KINDS}, got {self.reward_kind!r}")


class LeverArmFrequencyEnv(gym.Env):
    metadata = {"render_modes": []}

    def __init__(self, window, filter_cfg, initial_freqs_radps, cfg: EnvConfig = EnvConfig(),
                 reference_freqs_radps=None):
        """``initial_freqs_radps``: the model in force (each episode starts
        there); ``reference_freqs_radps``: centre of the search box (default
        the initial model)."""
        self.window = window
        self.filter_cfg = filter_cfg
        self.cfg = cfg
        self.w_init = np.asarray(initial_freqs_radps, float)
        self.w_ref = self.w_init.copy() if reference_freqs_radps is None else np.asarray(reference_freqs_radps, float)
        self.lo, self.hi = self.w_ref * (1 - cfg.max_rel), self.w_ref * (1 + cfg.max_rel)
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.w = self.w_init.copy()
        self.n_steps = 0
        self.n_passes = 0
        self.best_freqs_radps = self.w_init.copy()
        self.best_reward = -np.inf
        self.history: list[tuple[np.ndarray, float]] = []     # (frequencies, reward) of every pass
        self.deadline_s: float | None = None                    # time.monotonic() limit of the passes

    # ---- frequencies <-> normalised state -------------------------------------
    def to_obs(self, w) -> np.ndarray:
        return ((np.asarray(w, float) / self.w_ref - 1.0) / self.cfg.max_rel).astype(np.float32)

    def from_obs(self, x) -> np.ndarray:
        return self.w_ref * (1.0 + self.cfg.max_rel * np.clip(np.asarray(x, float), -1.0, 1.0))

    # ---- the reward of a model: one filter pass -----------------------------------
    def check_deadline(self) -> None:
        if self.deadline_s is not None and time.monotonic() > self.deadline_s:
            raise DeadlineExceeded(f"wall-time limit reached after {self.n_passes} passes")

    def evaluate(self, w) -> float:
        """Reward of the frequencies ``w`` (clipped to the search box): one pass."""
        self.check_deadline()
        w = np.clip(np.asarray(w, float), self.lo, self.hi)
        p = replay(self.window, self.filter_cfg, w)
        r = -position_error_m(p, self.cfg.reward_kind)
        self.n_passes += 1
        self.history.append((w.copy(), r))
        if r > self.best_reward:
            self.best_reward, self.best_freqs_radps = r, w.copy()
        return r

    # ---- Gymnasium API -------------------------------------------------------------
    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.w = self.w_init.copy()
        self.n_steps = 0
        return self.to_obs(self.w), {"freqs_radps": self.w.copy()}

    def step(self, action):
        a = np.clip(np.asarray(action, float), -1.0, 1.0)
        self.w = np.clip(self.w + a * self.cfg.action_scale * self.w_ref, self.lo, self.hi)
        r = self.evaluate(self.w)
        self.n_steps += 1
        return self.to_obs(self.w), r, False, self.n_steps >= self.cfg.max_steps, {"freqs_radps": self.w.copy()}
