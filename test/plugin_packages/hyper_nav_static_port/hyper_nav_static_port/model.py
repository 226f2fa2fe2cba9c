"""The static port's model and messages (no rclpy): the static pressure of
the US Standard Atmosphere 1976 at the true altitude, plus a constant bias
and white noise (Pa), at ``static_port.rate_hz``; one function makes the
messages for the node and for Monte Carlo."""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from hyper_nav_filter.conversions import s_to_stamp_fields
from hyper_nav_filter.core.atmosphere import pressure_Pa

TOPIC = "static_port/pressure"


@dataclass(frozen=True)
class StaticPortConfig:
    rate_hz: float = 10.0
    noise_pa: float = 0.5                      # white noise 1-sigma (Pa)
    bias_pa: float = 0.0                       # constant bias (Pa)

    @classmethod
    def from_block(cls, block: dict | None, prefix: str = "static_port.") -> "StaticPortConfig":
        block = dict(block or {})
        known = [f.name for f in fields(cls)]
        unknown = sorted(set(block) - set(known))
        if unknown:
            raise ValueError(f"{prefix}{unknown[0]}: unknown field (known: {', '.join(known)})")
        for k, v in block.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise ValueError(f"{prefix}{k}: expected a number, got {v!r}")
        cfg = cls(**{k: float(v) for k, v in block.items()})
        if not cfg.rate_hz > 0:
            raise ValueError(f"{prefix}rate_hz: expected a number > 0, got {cfg.rate_hz!r}")
        if cfg.noise_pa < 0:
            raise ValueError(f"{prefix}noise_pa: expected a number >= 0, got {cfg.noise_pa!r}")
        return cfg


def samples(sc, traj):
    """(t_s, pressure Pa, variance Pa^2) over the scenario's duration."""
    cfg = StaticPortConfig.from_block(sc.data.get("static_port"))
    n = int(np.floor(sc["duration_s"] * cfg.rate_hz + 1e-9))
    t_s = np.arange(1, n + 1) / cfg.rate_hz
    p_true = np.asarray(pressure_Pa(traj.truth(t_s).alt_m), float)
    p_pa = p_true + cfg.bias_pa + cfg.noise_pa * sc.rng("static_port").standard_normal(n)
    return t_s, p_pa, np.full(n, max(cfg.noise_pa, 1e-3) ** 2)


def fill(msg, t_s: float, p_pa: float, var_pa2: float, frame_id: str = "base_link"):
    """A sensor_msgs/FluidPressure (or any object of its shape) at epoch t_s."""
    msg.header.stamp.sec, msg.header.stamp.nanosec = s_to_stamp_fields(float(t_s))
    msg.header.frame_id = frame_id
    msg.fluid_pressure = float(p_pa)
    msg.variance = float(var_pa2)
    return msg


def messages(sc, traj, frame_id: str = "base_link") -> list:
    """[(t_s, topic, FluidPressure)]: what the node publishes."""
    from sensor_msgs.msg import FluidPressure
    t_s, p_pa, var = samples(sc, traj)
    return [(float(t), TOPIC, fill(FluidPressure(), t, p, v, frame_id)) for t, p, v in zip(t_s, p_pa, var)]
