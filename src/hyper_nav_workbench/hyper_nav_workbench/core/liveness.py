"""Liveness of a node graph from what its nodes say on ``/diagnostics``.

Every node publishes a status every ``diagnostics_period_s`` of wall time with
a ``heartbeat`` counter and its message counters: a producer's ``published
<topic>``, a consumer's ``received <topic>`` (the fusion node). From those,
and the sim time of ``/clock``, this core decides for each expected node and
each expected stream whether it is alive:

* node: ERROR when no status came for ``heartbeat_timeout_s`` of wall time
  (killed, crashed, hung) or none at all within ``startup_timeout_s``; OK
  after a status with ``finished: true`` (it ended by itself).
* stream: WARN (ERROR for a critical stream such as the IMU) when its count
  did not advance over ``timeout_s`` of sim time, or when every node that
  reported it went silent (its producer and consumer died). It is judged at
  every live node that reports it, the producers (``published <topic>``: a
  stream with a hole) and the consumers (``received <topic>``: a stream lost
  on the way), and the longest silence counts. Silence is measured
  between the reporter's own reports: from the stamp of the last message
  when the reporter gives it (``last <topic>``, sensors and player), else
  from the report at which the count last advanced, to its latest report, on
  the reporter's own sim time when it says it (``sim_time_s``) or the
  monitor's /clock otherwise, so neither the wall period of the reports nor a
  late /clock subscription blurs it; only sim time up to the scenario end
  (``end_s``) counts, since every stream stops there.

Pure Python, no rclpy: ``nodes/monitor.py`` feeds it and publishes its
verdicts; the unit tests drive it with synthetic statuses.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

OK, WARN, ERROR, STALE = "ok", "warn", "error", "stale"


@dataclass(frozen=True)
class StreamSpec:
    topic: str
    timeout_s: float          # sim seconds without progress before the stream is missing
    critical: bool = False    # ERROR instead of WARN (no IMU: nothing to navigate with)


@dataclass(frozen=True)
class LivenessConfig:
    nodes: tuple[str, ...]              # node names (DiagnosticStatus.hardware_id)
    streams: tuple[StreamSpec, ...]
    heartbeat_timeout_s: float = 5.0    # wall
    startup_timeout_s: float = 60.0     # wall
    end_s: float = math.inf             # sim time at which the streams end


@dataclass(frozen=True)
class Verdict:
    name: str                 # "node gnss", "stream imu/data_raw"
    level: str                # ok / warn / error / stale
    message: str
    since_s: float | None = None      # sim time the fault began (None: no fault)


@dataclass
class _Source:
    node: str
    kind: str                 # "received" (consumer) or "published" (producer)
    count: int = -1
    t_increase_s: float | None = None
    t_report_s: float | None = None
    t_last_stamp_s: float | None = None     # stamp of the last message, when reported


@dataclass
class _Node:
    last_wall_s: float | None = None
    last_sim_s: float | None = None
    finished: bool = False
    statuses: int = 0


@dataclass
class LivenessMonitor:
    cfg: LivenessConfig
    start_wall_s: float
    sim_s: float | None = None
    start_sim_s: float | None = None
    _nodes: dict = field(default_factory=dict)
    _sources: dict = field(default_factory=dict)      # topic -> {(node, kind): _Source}

    def __post_init__(self):
        self._nodes = {n: _Node() for n in self.cfg.nodes}
        self._sources = {s.topic: {} for s in self.cfg.streams}

    # ---- inputs ---------------------------------------------------------------
    def on_clock(self, sim_s: float) -> None:
        if self.start_sim_s is None:
            self.start_sim_s = sim_s
        self.sim_s = sim_s if self.sim_s is None else max(self.sim_s, sim_s)

    def on_status(self, node: str, values: dict, wall_s: float) -> None:
        """One DiagnosticStatus of ``node`` (its key/value pairs as strings)."""
        st = self._nodes.setdefault(node, _Node())
        try:
            own_sim = float(values.get("sim_time_s") or "nan")
        except ValueError:
            own_sim = float("nan")
        if own_sim == own_sim:                     # the reporter's own sim time advances ours too
            self.on_clock(own_sim)
        now = own_sim if own_sim == own_sim else self.sim_s
        st.last_wall_s, st.last_sim_s, st.statuses = wall_s, now, st.statuses + 1
        st.finished = st.finished or str(values.get("finished", "")).lower() == "true"
        if now is None:
            return
        stamps = {}
        for key, value in values.items():
            kind, _, topic = str(key).partition(" ")
            topic = topic.lstrip("/")
            if topic not in self._sources:
                continue
            try:
                if kind == "last":
                    stamps[topic] = float(value)
                    continue
                if kind not in ("received", "published"):
                    continue
                count = int(value)
            except ValueError:
                continue
            src = self._sources[topic].setdefault((node, kind), _Source(node, kind))
            if src.t_increase_s is None:          # first report: nothing yet, or some since the start
                src.t_increase_s = self.start_sim_s if count <= 0 else now
                src.count = count
            elif count > src.count:
                src.t_increase_s, src.count = now, count
            src.t_report_s = now
        for topic, t in stamps.items():
            src = self._sources[topic].get((node, "published"))
            if src is not None:
                src.t_last_stamp_s = t

    # ---- verdicts -------------------------------------------------------------
    def alive(self, node: str, wall_s: float) -> bool:
        st = self._nodes.get(node)
        return st is not None and st.last_wall_s is not None and \
            (st.finished or wall_s - st.last_wall_s <= self.cfg.heartbeat_timeout_s)

    def node_verdict(self, node: str, wall_s: float) -> Verdict:
        st = self._nodes.get(node, _Node())
        name = f"node {node}"
        if st.last_wall_s is None:
            waited = wall_s - self.start_wall_s
            if waited > self.cfg.startup_timeout_s:
                return Verdict(name, ERROR, f"never started: no status within {waited:.0f} s", self.start_sim_s)
            return Verdict(name, STALE, "waiting for its first status")
        if st.finished:
            return Verdict(name, OK, "finished")
        silent = wall_s - st.last_wall_s
        if silent > self.cfg.heartbeat_timeout_s:
            at = "" if st.last_sim_s is None else f", last at t = {st.last_sim_s:.1f} s"
            return Verdict(name, ERROR, f"dead: no heartbeat for {silent:.1f} s{at}", st.last_sim_s)
        return Verdict(name, OK, "alive")

    def stream_verdict(self, spec: StreamSpec, wall_s: float) -> Verdict:
        name = f"stream {spec.topic}"
        bad = ERROR if spec.critical else WARN
        if self.sim_s is None:
            return Verdict(name, STALE, "waiting for /clock")
        sources = self._sources[spec.topic].values()
        live = [s for s in sources if self.alive(s.node, wall_s)]
        if not live:
            if sources:                      # every node that reported it went silent
                last = max(s.t_report_s for s in sources)
                dead = ", ".join(sorted({s.node for s in sources}))
                return Verdict(name, bad, f"lost: {dead} reported it until t = {last:.1f} s and went silent",
                               last)
            if wall_s - self.start_wall_s > self.cfg.startup_timeout_s:
                return Verdict(name, bad, "no node has reported it", self.start_sim_s)
            return Verdict(name, STALE, "no node reports it yet")
        def since(s):
            if s.t_last_stamp_s is not None:
                return s.t_last_stamp_s
            return s.t_increase_s

        def silence(s):
            return min(s.t_report_s, self.cfg.end_s) - since(s)
        worst = max(live, key=lambda s: (silence(s), s.kind == "received"))     # ties: say it at the consumer
        silent = silence(worst)
        where = "received at" if worst.kind == "received" else "published by"
        if silent > spec.timeout_s:
            return Verdict(name, bad, f"missing: nothing {where} {worst.node} for {silent:.1f} s "
                                      f"(since t = {since(worst):.1f} s)", since(worst))
        return Verdict(name, OK, f"{worst.count} {where.split()[0]} ({where} {worst.node})")

    def evaluate(self, wall_s: float) -> list[Verdict]:
        """Every node and stream verdict, nodes first."""
        return [self.node_verdict(n, wall_s) for n in self.cfg.nodes] + \
            [self.stream_verdict(s, wall_s) for s in self.cfg.streams]
