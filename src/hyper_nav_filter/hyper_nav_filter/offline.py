"""Run the fusion core offline over recorded messages (no ROS, no DDS).

``run_offline(records, cfg, initial, sources)`` takes (topic, message) pairs
and feeds them through the same declared sources (``hyper_nav_filter.sources``)
into the same ``FusionEngine`` as the live node. By default
(``order="live"``) the records are fed in the fusion node's own order,
rebuilt from their stamps and the node's ``nav/late_inputs`` reports
(``replay_order``): a bag's log order is the recorder's, not the node's, so
the records may come in any order and the result is the live node's, bit for
bit. ``order="given"`` feeds them as given: an arrival order to test the
engine with.
"""
from __future__ import annotations

from .core.config import FilterConfig
from .core.fusion import FusionEngine, Solution
from .core.nav_state import NavState
from .replay_order import live_order, split_late_inputs
from .sources import DEFAULT_TABLE
from .sources.router import SourceRouter

ORDERS = ("live", "given")


def replay_records(records, sources: dict | None = None, late_inputs=None, order: str = "live"):
    """(records to feed, the ReplayOrder or None): the inputs of ``records``
    in the requested order. ``late_inputs`` (LateInput reports or messages)
    default to the ``nav/late_inputs`` messages found among the records."""
    if order not in ORDERS:
        raise ValueError(f"order: expected one of {ORDERS}, got {order!r}")
    inputs, found = split_late_inputs(records)
    if order == "given":
        return inputs, None
    table = sources or DEFAULT_TABLE
    imu_topic = next(e["topic"] for e in table.values() if e.get("type") == "imu")
    ro = live_order(inputs, found if late_inputs is None else late_inputs, imu_topic)
    return ro.records, ro


def run_offline(records, cfg: FilterConfig, initial: NavState, sources: dict | None = None,
                final: bool = False, keep_history: bool = False, order: str = "live",
                late_inputs=None, keep_current: bool = False) -> tuple[list[Solution], FusionEngine]:
    """Solutions released by the engine (all of them with ``final``) and the
    engine; ``sources`` is the table of ``filter.sources`` (default: IMU and
    loosely coupled GNSS); ``keep_history`` keeps every epoch for ``smooth``;
    ``order`` and ``late_inputs`` as ``replay_records``. The engine's
    ``replay`` attribute holds the ReplayOrder (None with ``order="given"``);
    with ``keep_current`` its ``current_log`` holds the current-time state of
    every IMU sample (the live node's ``nav/state``, in its order)."""
    feed, ro = replay_records(records, sources, late_inputs, order)
    eng = FusionEngine(cfg, initial, keep_history=keep_history)
    eng.replay = ro
    eng.current_log = [] if keep_current else None
    router = SourceRouter(eng, sources or DEFAULT_TABLE)
    out: list[Solution] = []
    for topic, msg in feed:
        out.extend(router.handle_topic(topic, msg)[1])
    if final:
        out.extend(eng.release(final=True))
    return out, eng


def smooth(eng: FusionEngine) -> list[Solution]:
    """Fixed-interval RTS smoothing of a finished offline pass
    (``run_offline(..., final=True, keep_history=True)``)."""
    from .core.smoother import rts_smooth
    return rts_smooth(eng.full_history(), eng.cfg, eng.kf)
