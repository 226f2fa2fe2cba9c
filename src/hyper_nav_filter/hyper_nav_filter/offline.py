"""Run the fusion core offline over recorded messages (no ROS, no DDS).

``run_offline(records, cfg, initial)`` takes (topic, message) pairs in the
order the node would have received them (a bag's log order) and feeds them
to the same ``FusionEngine`` through the same conversions as the live node.
With ``tight`` (a ``TightGnssInput``, the node's ``filter.gnss_mode: tight``)
it takes ``gnss/raw`` and ``gnss/ephemeris`` through the node's
``TightGnssHandler`` instead of ``gnss/fix`` / ``gnss/vel``.
"""
from __future__ import annotations

from . import conversions
from .core.config import FilterConfig
from .core.fusion import FusionEngine, Solution
from .core.gnss.raw_to_pseudoranges import TightGnssInput
from .core.nav_state import NavState
from .tight_input import TightGnssHandler

TOPICS = {"imu": "imu/data_raw", "fix": "gnss/fix", "vel": "gnss/vel", "raw": "gnss/raw",
          "ephemeris": "gnss/ephemeris"}


def run_offline(records, cfg: FilterConfig, initial: NavState, topics: dict | None = None,
                final: bool = False, tight: TightGnssInput | None = None,
                keep_history: bool = False) -> tuple[list[Solution], FusionEngine]:
    """Solutions released by the engine (all of them with ``final``) and the
    engine; ``keep_history`` keeps every epoch for ``smooth``."""
    t = dict(TOPICS, **(topics or {}))
    eng = FusionEngine(cfg, initial, keep_history=keep_history)
    handler = TightGnssHandler(eng, tight) if tight is not None else None
    out: list[Solution] = []
    for topic, msg in records:
        topic = topic.lstrip("/")
        if topic == t["imu"]:
            eng.counters["imu_msgs"] += 1
            eng.add_imu_rates(*conversions.imu_rates(msg))
            if handler is not None:
                handler.feed()
            out.extend(eng.release())
        elif handler is not None:
            if topic == t["raw"]:
                handler.on_raw(msg)
            elif topic == t["ephemeris"]:
                handler.on_ephemeris(msg)
        elif topic == t["fix"]:
            eng.counters["gnss_fix_msgs"] += 1
            eng.add_measurement(conversions.gnss_position(msg))
        elif topic == t["vel"]:
            eng.counters["gnss_vel_msgs"] += 1
            eng.add_measurement(conversions.gnss_velocity(msg))
    if final:
        out.extend(eng.release(final=True))
    return out, eng


def smooth(eng: FusionEngine) -> list[Solution]:
    """Fixed-interval RTS smoothing of a finished offline pass
    (``run_offline(..., final=True, keep_history=True)``)."""
    from .core.smoother import rts_smooth
    return rts_smooth(eng.full_history(), eng.cfg, eng.kf)
