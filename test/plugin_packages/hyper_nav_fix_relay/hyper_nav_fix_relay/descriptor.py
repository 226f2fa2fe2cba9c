"""The fix relay declared to the launcher and the scenario loader: its
executable, the ``fix_relay`` block and its validator, inputs, outputs and
parameters (no rclpy here)."""
from __future__ import annotations

from dataclasses import dataclass

from hyper_nav_filter.aiding_nodes import AidingNode, flat_parameters

FIELDS = ("enabled", "topic", "sigma_scale")


@dataclass(frozen=True)
class FixRelayConfig:
    enabled: bool = True
    topic: str = "relay/fix"
    sigma_scale: float = 1.0                   # the relayed fixes' 1-sigma = the receiver's x sigma_scale

    @classmethod
    def from_block(cls, block: dict | None, prefix: str = "fix_relay.") -> "FixRelayConfig":
        block = dict(block or {})
        unknown = sorted(set(block) - set(FIELDS))
        if unknown:
            raise ValueError(f"{prefix}{unknown[0]}: unknown field (known: {', '.join(FIELDS)})")
        cfg = cls(**block)
        if isinstance(cfg.sigma_scale, bool) or not isinstance(cfg.sigma_scale, (int, float)) or \
                not cfg.sigma_scale > 0:
            raise ValueError(f"{prefix}sigma_scale: expected a number > 0, got {cfg.sigma_scale!r}")
        if not isinstance(cfg.topic, str) or not cfg.topic:
            raise ValueError(f"{prefix}topic: expected a topic name, got {cfg.topic!r}")
        return cfg


def parameters(sc) -> dict:
    """The node's ROS parameters from a scenario: its block (defaults filled) and the queue depth."""
    cfg = FixRelayConfig.from_block(sc.data.get("fix_relay"))
    return {**flat_parameters({"topic": cfg.topic, "sigma_scale": float(cfg.sigma_scale)}, "fix_relay"),
            "qos.depth": int(sc["graph.qos_depth"])}


FIX_RELAY = AidingNode(
    name="fix_relay", package="hyper_nav_fix_relay", executable="fix_relay_node", block="fix_relay",
    validate=FixRelayConfig.from_block, parameters=parameters,
    inputs=lambda block: {"gnss/fix"}, outputs=lambda block: [FixRelayConfig.from_block(block).topic],
    output_wait_parameter="min_output_subscribers")
