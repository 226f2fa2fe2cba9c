"""Run the fusion core offline over recorded messages (no ROS, no DDS).

``run_offline(records, cfg, initial, sources)`` takes (topic, message) pairs
in the order the node would have received them (a bag's log order) and feeds
them through the same declared sources (``hyper_nav_filter.sources``) into
the same ``FusionEngine`` as the live node.
"""
from __future__ import annotations

from .core.config import FilterConfig
from .core.fusion import FusionEngine, Solution
from .core.nav_state import NavState
from .sources import DEFAULT_TABLE
from .sources.router import SourceRouter


def run_offline(records, cfg: FilterConfig, initial: NavState, sources: dict | None = None,
                final: bool = False, keep_history: bool = False) -> tuple[list[Solution], FusionEngine]:
    """Solutions released by the engine (all of them with ``final``) and the
    engine; ``sources`` is the table of ``filter.sources`` (default: IMU and
    loosely coupled GNSS); ``keep_history`` keeps every epoch for ``smooth``."""
    eng = FusionEngine(cfg, initial, keep_history=keep_history)
    router = SourceRouter(eng, sources or DEFAULT_TABLE)
    out: list[Solution] = []
    for topic, msg in records:
        out.extend(router.handle_topic(topic, msg)[1])
    if final:
        out.extend(eng.release(final=True))
    return out, eng


def smooth(eng: FusionEngine) -> list[Solution]:
    """Fixed-interval RTS smoothing of a finished offline pass
    (``run_offline(..., final=True, keep_history=True)``)."""
    from .core.smoother import rts_smooth
    return rts_smooth(eng.full_history(), eng.cfg, eng.kf)
