"""Run the fusion core offline over recorded messages (no ROS, no DDS).

``run_offline(records, cfg, initial)`` takes (topic, message) pairs in the
order the node would have received them (a bag's log order) and feeds them
to the same ``FusionEngine`` through the same conversions as the live node.
"""
from __future__ import annotations

from . import conversions
from .core.config import FilterConfig
from .core.fusion import FusionEngine, Solution
from .core.nav_state import NavState

TOPICS = {"imu": "imu/data_raw", "fix": "gnss/fix", "vel": "gnss/vel"}


def run_offline(records, cfg: FilterConfig, initial: NavState, topics: dict | None = None,
                final: bool = False) -> tuple[list[Solution], FusionEngine]:
    t = dict(TOPICS, **(topics or {}))
    eng = FusionEngine(cfg, initial)
    out: list[Solution] = []
    for topic, msg in records:
        topic = topic.lstrip("/")
        if topic == t["imu"]:
            eng.counters["imu_msgs"] += 1
            eng.add_imu_rates(*conversions.imu_rates(msg))
            out.extend(eng.release())
        elif topic == t["fix"]:
            eng.counters["gnss_fix_msgs"] += 1
            eng.add_measurement(conversions.gnss_position(msg))
        elif topic == t["vel"]:
            eng.counters["gnss_vel_msgs"] += 1
            eng.add_measurement(conversions.gnss_velocity(msg))
    if final:
        out.extend(eng.release(final=True))
    return out, eng
