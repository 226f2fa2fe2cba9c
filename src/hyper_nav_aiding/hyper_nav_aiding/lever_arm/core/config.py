"""The lever-arm learning node's parameters, declared once
(``hyper_nav_filter.core.params.ParamSpec``: type, default, range,
description): they validate the scenario's ``lever_arm_learning:`` block
(nested mapping, dotted names below), declare the node's ROS parameters with
descriptors, and fill one typed object; errors name the field
(``lever_arm_learning.trigger.threshold_m: expected a number, got 'three'``).
"""
from __future__ import annotations

from dataclasses import dataclass

from hyper_nav_filter.core.params import FLOAT, INT, STR, ConfigError, ParamSpec, check_all, nonneg, positive

from hyper_nav_aiding.lever_arm.core import ddpg
from hyper_nav_aiding.lever_arm.core.env import REWARD_KINDS, EnvConfig
from hyper_nav_aiding.lever_arm.core.reestimate import METHODS, ReestimationConfig
from hyper_nav_aiding.lever_arm.core.trigger import TriggerConfig

BLOCK = "lever_arm_learning"

PARAMS = (
    nonneg("trigger.threshold_m", FLOAT, 3.0, "fire when the mean position residual |nav - gnss| exceeds this (m)"),
    nonneg("trigger.release_m", FLOAT, 2.0, "re-arm once the statistic is below this (m, < threshold: hysteresis)"),
    nonneg("trigger.cooldown_s", FLOAT, 30.0, "no new firing within this time after one (s, sim time)"),
    ParamSpec("trigger.averaging_s", FLOAT, 2.0, "moving average of the residual vector (s; 0: latest fix only)",
              lo=0.0, hi=600.0),
    ParamSpec("window_s", FLOAT, 10.0, "length of the re-estimation window of IMU and GNSS data (s)", lo=0.5, hi=600.0),
    ParamSpec("state_period_s", FLOAT, 1.0, "keep a fused state (window start candidate) every this (s)",
              lo=0.02, hi=60.0),
    ParamSpec("method", STR, "ddpg", "ddpg (the paper) or cmaes, nelder_mead, max_likelihood", choices=METHODS),
    ParamSpec("budget_passes", INT, 250, "filter passes per re-estimation (Table 3: 50 episodes x 5 steps)",
              lo=8, hi=100000),
    ParamSpec("timeout_s", FLOAT, 120.0, "wall-time limit of one re-estimation (s); past it the model stays",
              lo=1e-3, hi=3600.0),
    positive("worker_grace_s", FLOAT, 5.0, "a job still running timeout_s + this (s) is killed"),
    ParamSpec("worker_nice", INT, 10, "scheduling priority increment of the worker process (fusion keeps real time)",
              lo=0, hi=19),
    nonneg("min_improvement_m", FLOAT, 0.0, "publish only if the reward improves by more than this (m)"),
    ParamSpec("seed", INT, 0, "seed of the agent / identifier", lo=0, hi=2**31 - 1),
    ParamSpec("update_delay_s", FLOAT, 5.0, "model update epoch = trigger epoch + this (s), so it does not depend "
              "on how long the job took in wall time, unless the job ends later (then: newest IMU + update_lead_s)",
              lo=0.0, hi=600.0),
    ParamSpec("update_lead_s", FLOAT, 0.1, "model update epoch of a job ending after trigger + update_delay_s: "
              "newest IMU stamp seen + this (s)", lo=0.0, hi=10.0),
    ParamSpec("gnss_hold_s", FLOAT, 2.0, "a fused state is taken once a GNSS fix stamped at or after it has come, "
              "or the IMU is this far past it (a GNSS outage): the residuals and windows do not depend on the "
              "order the topics arrive in (s)", lo=0.0, hi=60.0),
    ParamSpec("env.max_rel", FLOAT, 0.25, "search box: model in force x (1 +- max_rel)", lo=1e-3, hi=0.99),
    ParamSpec("env.action_scale", FLOAT, 0.05, "largest frequency change per step, relative", lo=1e-4, hi=0.99),
    ParamSpec("env.max_steps", INT, 5, "steps per episode (Table 3: 5)", lo=1, hi=1000),
    ParamSpec("env.reward_kind", STR, "rms", "reward = -position error: rms over the window or final fix",
              choices=REWARD_KINDS),
    ParamSpec("agent.episodes", INT, 50, "DDPG episodes (Table 3: 50)", lo=1, hi=100000),
    ParamSpec("agent.actor_lr", FLOAT, 0.001, "actor learning rate (Table 3)", lo=0.0, hi=1.0, lo_open=True),
    ParamSpec("agent.critic_lr", FLOAT, 0.002, "critic learning rate (Table 3)", lo=0.0, hi=1.0, lo_open=True),
    ParamSpec("agent.memory", INT, 250, "replay memory capacity (Table 3)", lo=1, hi=1000000),
    ParamSpec("agent.tau", FLOAT, 0.01, "soft update of the target networks (Table 3)", lo=0.0, hi=1.0, lo_open=True),
    ParamSpec("agent.batch", INT, 32, "minibatch size (our choice)", lo=1, hi=4096),
    ParamSpec("agent.gamma", FLOAT, 0.9, "discount (our choice)", lo=0.0, hi=1.0),
    ParamSpec("agent.updates_per_step", INT, 10, "gradient steps per environment step (our choice)", lo=1, hi=1000),
    positive("diagnostics_period_s", FLOAT, 1.0, "period of /diagnostics (s, wall clock)"),
    ParamSpec("qos.depth", INT, 2000, "subscription depth", lo=1, hi=100000),
    ParamSpec("load_topic", STR, "", "sensor_msgs/Imu topic of the structure's load sensor (seed 000 eq. 22's u_q; "
              "the windows carry it, as the fusion node's imu source takes it); empty: none"),
)


@dataclass(frozen=True)
class LeverArmLearningConfig:
    trigger: TriggerConfig
    window_s: float
    state_period_s: float
    reestimation: ReestimationConfig
    update_lead_s: float
    update_delay_s: float
    gnss_hold_s: float
    worker_grace_s: float
    worker_nice: int
    diagnostics_period_s: float
    qos_depth: int
    load_topic: str = ""

    @classmethod
    def from_flat(cls, values: dict, prefix: str = BLOCK + ".") -> "LeverArmLearningConfig":
        """From dotted names (ROS parameters or the flattened block); missing
        names take the defaults; ConfigError (a ValueError) names the field."""
        v = check_all(PARAMS, values, prefix)
        try:
            trig = TriggerConfig(v["trigger.threshold_m"], v["trigger.release_m"], v["trigger.cooldown_s"],
                                 v["trigger.averaging_s"])
            env = EnvConfig(v["env.max_rel"], v["env.action_scale"], v["env.max_steps"], v["env.reward_kind"])
            agent = ddpg.DDPGConfig(actor_lr=v["agent.actor_lr"], critic_lr=v["agent.critic_lr"],
                                    episodes=v["agent.episodes"], steps=v["env.max_steps"], memory=v["agent.memory"],
                                    tau=v["agent.tau"], batch=v["agent.batch"], gamma=v["agent.gamma"],
                                    updates_per_step=v["agent.updates_per_step"])
            rc = ReestimationConfig(v["method"], env, agent, v["budget_passes"], v["min_improvement_m"], True,
                                    v["seed"], v["timeout_s"])
        except ValueError as exc:
            raise ConfigError(f"{prefix}{exc}") from None
        return cls(trig, v["window_s"], v["state_period_s"], rc, v["update_lead_s"], v["update_delay_s"], v["gnss_hold_s"], v["worker_grace_s"],
                   v["worker_nice"], v["diagnostics_period_s"], v["qos.depth"], v["load_topic"])

    @classmethod
    def from_block(cls, block: dict | None, prefix: str = BLOCK) -> "LeverArmLearningConfig":
        """From the scenario's nested ``lever_arm_learning:`` mapping."""
        return cls.from_flat(flatten(block or {}, prefix), prefix + ".")


def flatten(block: dict, prefix: str = BLOCK) -> dict:
    """{'trigger': {'threshold_m': 3}} -> {'trigger.threshold_m': 3}."""
    if not isinstance(block, dict):
        raise ConfigError(f"{prefix}: expected a mapping, got {block!r}")
    out = {}
    for k, v in block.items():
        if isinstance(v, dict):
            out.update({f"{k}.{kk}": vv for kk, vv in flatten(v, f"{prefix}.{k}").items()})
        else:
            out[k] = v
    return out
