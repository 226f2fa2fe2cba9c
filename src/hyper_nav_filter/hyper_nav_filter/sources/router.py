"""The fusion inputs: declared sources routed into one engine. Shared by the
fusion node (live, one call per message) and the offline replay (a bag's
messages in log order), so both run exactly the same code."""
from __future__ import annotations

from ..core.fusion import FusionEngine, Solution
from ..core.params import ConfigError
from .base import SourceType, make_sources, parse_sources


class SourceRouter:
    def __init__(self, engine: FusionEngine, table: dict):
        self.engine = engine
        self.specs = parse_sources(table)
        # the fusion horizon: the largest declared source delay (or the configured one)
        for s in self.specs:
            if s.delay_s > engine.cfg.output_delay_s:
                raise ConfigError(f"filter.sources.{s.id}.delay_s: {s.delay_s:g} s is beyond filter.config."
                                  f"output_delay_s ({engine.cfg.output_delay_s:g} s), the record's horizon")
        delay = max([engine.cfg.fusion_delay_s] + [s.delay_s for s in self.specs])
        if delay != engine.fusion_delay_s:
            engine.set_fusion_delay(delay)
        self.sources: list[SourceType] = make_sources(self.specs, engine.cfg)
        self.routes: dict[str, list] = {}         # topic -> [(source, role)]: sources may share a topic
        for src in self.sources:                  # (e.g. two gnss_raw sources and their gnss/ephemeris)
            for inp in src.inputs():
                self.routes.setdefault(inp.topic.lstrip("/"), []).append((src, inp.role))

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
        """Route by topic name to every source taking it (as the node's one
        subscription per source input does); messages of other topics are
        ignored. Returns the first rejection reason and the solutions released."""
        reason, sols = None, []
        for src, role in self.routes.get(topic.lstrip("/"), ()):
            r, s = self.handle(src, role, msg)
            reason = reason or r
            sols += s
        return reason, sols

    def diagnostics(self) -> dict:
        out = {}
        for s in self.sources:
            out.update(s.diagnostics())
        return out
