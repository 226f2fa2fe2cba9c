"""The fusion inputs: declared sources routed into one engine. Shared by the
fusion node (live, one call per message) and the offline replay (a bag's
messages in log order), so both run exactly the same code."""
from __future__ import annotations

from ..core.fusion import FusionEngine, Solution
from .base import SourceType, make_sources, parse_sources


class SourceRouter:
    def __init__(self, engine: FusionEngine, table: dict):
        self.engine = engine
        self.specs = parse_sources(table)
        self.sources: list[SourceType] = make_sources(self.specs, engine.cfg)
        self.routes = {}
        for src in self.sources:
            for inp in src.inputs():
                self.routes[inp.topic.lstrip("/")] = (src, inp.role)

    def topics(self) -> list[str]:
        return list(self.routes)

    def handle(self, src: SourceType, role: str, msg) -> tuple[str | None, list[Solution]]:
        """One message of a source: (rejection reason or None, solutions released now)."""
        reason = src.on_message(role, msg, self.engine)
        if not src.drives_time:
            return reason, []
        for s in self.sources:
            s.on_imu(self.engine)
        return reason, self.engine.release()

    def handle_topic(self, topic: str, msg) -> tuple[str | None, list[Solution]]:
        """Route by topic name; messages of other topics are ignored."""
        r = self.routes.get(topic.lstrip("/"))
        if r is None:
            return None, []
        return self.handle(r[0], r[1], msg)

    def diagnostics(self) -> dict:
        out = {}
        for s in self.sources:
            out.update(s.diagnostics())
        return out
