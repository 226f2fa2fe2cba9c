"""The lever-arm learning node's parameters: one table (name, default,
range, description), read from the scenario's ``lever_arm_learning:`` block
(nested mapping, dotted names below) or from ROS parameters, into one typed
object; errors name the field (``lever_arm_learning.trigger.threshold_m: ...``).
"""
from __future__ import annotations

from dataclasses import dataclass

from . import ddpg
from .env import REWARD_KINDS, EnvConfig
from .reestimate import METHODS, ReestimationConfig
from .trigger import TriggerConfig

BLOCK = "lever_arm_learning"

# name: (default, (min, max) or choices, description)
PARAMETERS = {
    "trigger.threshold_m": (3.0, (0.0, 1e6), "fire when the mean position residual |nav - gnss| exceeds this (m)"),
    "trigger.release_m": (2.0, (0.0, 1e6), "re-arm once the statistic is below this (m, < threshold: hysteresis)"),
    "trigger.cooldown_s": (30.0, (0.0, 1e6), "no new firing within this time after one (s, sim time)"),
    "trigger.averaging_s": (2.0, (0.0, 600.0), "moving average of the residual vector (s; 0: latest fix only)"),
    "window_s": (10.0, (0.5, 600.0), "length of the re-estimation window of IMU and GNSS data (s)"),
    "state_period_s": (1.0, (0.02, 60.0), "keep a fused state (window start candidate) every this (s)"),
    "method": ("ddpg", METHODS, "ddpg (the paper) or cmaes, nelder_mead, max_likelihood"),
    "budget_passes": (250, (8, 100000), "filter passes per re-estimation (Table 3: 50 episodes x 5 steps)"),
    "timeout_s": (120.0, (1.0, 3600.0), "wall-time limit of one re-estimation (s); past it the model stays"),
    "min_improvement_m": (0.0, (0.0, 1e6), "publish only if the reward improves by more than this (m)"),
    "seed": (0, (0, 2**31 - 1), "seed of the agent / identifier"),
    "update_lead_s": (0.1, (0.0, 10.0), "model update epoch = newest IMU stamp seen + this (s)"),
    "env.max_rel": (0.25, (1e-3, 0.99), "search box: model in force x (1 +- max_rel)"),
    "env.action_scale": (0.05, (1e-4, 0.99), "largest frequency change per step, relative"),
    "env.max_steps": (5, (1, 1000), "steps per episode (Table 3: 5)"),
    "env.reward_kind": ("rms", REWARD_KINDS, "reward = -position error: rms over the window or final fix"),
    "agent.episodes": (50, (1, 100000), "DDPG episodes (Table 3: 50)"),
    "agent.actor_lr": (0.001, (1e-7, 1.0), "actor learning rate (Table 3)"),
    "agent.critic_lr": (0.002, (1e-7, 1.0), "critic learning rate (Table 3)"),
    "agent.memory": (250, (1, 1000000), "replay memory capacity (Table 3)"),
    "agent.tau": (0.01, (1e-6, 1.0), "soft update of the target networks (Table 3)"),
    "agent.batch": (32, (1, 4096), "minibatch size (our choice)"),
    "agent.gamma": (0.9, (0.0, 1.0), "discount (our choice)"),
    "diagnostics_period_s": (1.0, (0.05, 60.0), "period of /diagnostics (s, wall clock)"),
    "qos.depth": (2000, (1, 100000), "subscription depth"),
}


@dataclass(frozen=True)
class LeverArmLearningConfig:
    trigger: TriggerConfig
    window_s: float
    state_period_s: float
    reestimation: ReestimationConfig
    update_lead_s: float
    diagnostics_period_s: float
    qos_depth: int

    @classmethod
    def defaults(cls) -> dict:
        return {k: v[0] for k, v in PARAMETERS.items()}

    @classmethod
    def from_flat(cls, values: dict, prefix: str = BLOCK) -> "LeverArmLearningConfig":
        """From dotted names (ROS parameters); missing names take the defaults."""
        unknown = sorted(set(values) - set(PARAMETERS))
        if unknown:
            raise ValueError(f"{prefix}: unknown field(s) {unknown}")
        v = {**cls.defaults(), **values}
        for name, (default, rng, _) in PARAMETERS.items():
            x = v[name]
            where = f"{prefix}.{name}"
            if isinstance(default, str):
                if x not in rng:
                    raise ValueError(f"{where}: expected one of {list(rng)}, got {x!r}")
                continue
            if isinstance(x, bool) or not isinstance(x, (int, float)):
                raise ValueError(f"{where}: expected a number, got {x!r}")
            if isinstance(default, int) and int(x) != x:
                raise ValueError(f"{where}: expected an integer, got {x!r}")
            if not rng[0] <= x <= rng[1]:
                raise ValueError(f"{where}: must be in [{rng[0]}, {rng[1]}], got {x!r}")
        try:
            trig = TriggerConfig(float(v["trigger.threshold_m"]), float(v["trigger.release_m"]),
                                 float(v["trigger.cooldown_s"]), float(v["trigger.averaging_s"]))
            env = EnvConfig(float(v["env.max_rel"]), float(v["env.action_scale"]), int(v["env.max_steps"]),
                            v["env.reward_kind"])
            agent = ddpg.DDPGConfig(actor_lr=float(v["agent.actor_lr"]), critic_lr=float(v["agent.critic_lr"]),
                                    episodes=int(v["agent.episodes"]), steps=int(v["env.max_steps"]),
                                    memory=int(v["agent.memory"]), tau=float(v["agent.tau"]),
                                    batch=int(v["agent.batch"]), gamma=float(v["agent.gamma"]))
            rc = ReestimationConfig(v["method"], env, agent, int(v["budget_passes"]), float(v["min_improvement_m"]),
                                    True, int(v["seed"]), float(v["timeout_s"]))
        except ValueError as exc:
            raise ValueError(f"{prefix}.{exc}") from None
        return cls(trig, float(v["window_s"]), float(v["state_period_s"]), rc, float(v["update_lead_s"]),
                   float(v["diagnostics_period_s"]), int(v["qos.depth"]))

    @classmethod
    def from_block(cls, block: dict | None, prefix: str = BLOCK) -> "LeverArmLearningConfig":
        """From the scenario's nested ``lever_arm_learning:`` mapping."""
        return cls.from_flat(flatten(block or {}, prefix), prefix)


def flatten(block: dict, prefix: str = BLOCK) -> dict:
    """{'trigger': {'threshold_m': 3}} -> {'trigger.threshold_m': 3}."""
    if not isinstance(block, dict):
        raise ValueError(f"{prefix}: expected a mapping, got {block!r}")
    out = {}
    for k, v in block.items():
        if isinstance(v, dict):
            out.update({f"{k}.{kk}": vv for kk, vv in flatten(v, f"{prefix}.{k}").items()})
        else:
            out[k] = v
    return out
