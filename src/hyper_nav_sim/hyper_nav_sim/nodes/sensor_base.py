"""Base class of the clock-driven sensor nodes.

A sensor node loads the scenario, computes its own measurement stream from
the deterministic truth (``hyper_nav_sim.core``), waits until each of its
publishers has ``min_subscribers`` matched subscriptions (a topic of
``wait_topics``: its own count of ``wait_counts``, when its consumers are
not those of the node's other topics), then subscribes to
``/clock`` and publishes every sample whose release time (epoch + latency)
has been reached. ``header.stamp`` is always the measurement epoch.

With a commanded flight (a scenario ``guidance:`` and ``flight:`` block,
issue 36) the node flies a mirror of the truth node's flight from
``flight/steps`` (``follow_flight``, ``flight_mirror``) and queues each
step's samples as it is flown; it then allows no /clock past the flight it
knows of (+ ``clock.lead_s``).

Its ``/diagnostics`` status (every ``diagnostics_period_s`` of wall time,
from ``graph.diagnostics_period_s``) carries ``heartbeat``, ``scheduled
<topic>`` (the node's whole stream), ``published <topic>``, ``last <topic>``
(stamp of the last message) and ``sim_time_s``, so the liveness monitor and
the report see a stream that stopped early, and when.

On ``/graph/allowance`` (``hyper_nav_filter.clock_gate``) it allows the
``/clock`` it has worked through + ``clock.lead_s`` (inf once its whole
stream is out): a sensor node starved of CPU or frozen holds the clock,
instead of releasing seconds of data in one burst when it resumes, deeper
than its consumers' queues (issue 33). Waited for when the time source lists
it (``run_graph`` does, with ``graph.clock_gate``).
"""
from __future__ import annotations

import math

import numpy as np
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from hyper_nav_filter.clock_gate import ClockAllowance
from hyper_nav_filter.conversions import s_to_stamp_fields, stamp_to_s
from hyper_nav_filter.ros_util import declare_params, publisher_qos

from ..core.scenario import load_scenario
from .params import SCENARIO, SENSOR, SENSOR_FROM_SCENARIO, with_scenario
from .status import NodeStatus


class ClockDrivenSensor(Node):
    def __init__(self, name: str):
        super().__init__(name)
        self.scenario = load_scenario(declare_params(self, (SCENARIO,))["scenario"])
        p = declare_params(self, with_scenario(SENSOR, self.scenario, SENSOR_FROM_SCENARIO))
        self.min_subscribers = p["min_subscribers"]
        self.declare_parameter("wait_counts", [0])
        counts = list(self.get_parameter("wait_counts").value) if p["wait_topics"] else []
        if len(counts) != len(p["wait_topics"]):
            raise ValueError(f"wait_counts {counts} must give one count per wait_topics entry {p['wait_topics']}")
        self.waits = {t.lstrip("/"): int(n) for t, n in zip(p["wait_topics"], counts)}
        self.qos = publisher_qos(p["qos.depth"])
        self.latency_s = 0.0
        self.status = NodeStatus(self, f"hyper_nav_sim: {name}")
        self.published = {}
        self.scheduled = {}
        self.last_stamp = {}
        self.sim_time_s = None
        self._queue = []        # list of (release_t_s, epoch_t_s, topic, make_msg)
        self._next = 0
        self._done_reported = False
        self._clock_sub = None
        self.mirror = None                      # a commanded flight's mirror (follow_flight)
        self.lead_s = p["clock.lead_s"]
        # no allowance before the /clock subscription exists (clock_gate: the time source holds the clock
        # until it has heard this node)
        self.allowance = ClockAllowance(self, source=self._allowance, ready=lambda: self._clock_sub is not None)
        self._wait_timer = self.create_timer(0.05, self._start_when_ready)
        self.create_timer(p["diagnostics_period_s"], self.publish_diagnostics)

    def publishers_to_match(self):
        """Publishers that must see ``min_subscribers`` matched subscriptions
        before data flows; an entry (publisher, n) asks for n instead (for
        topics that other subscribers take, e.g. gnss/raw)."""
        raise NotImplementedError

    def schedule(self, epochs_s, topic_publisher, make_msg):
        """Queue messages: make_msg(i) builds message i (epoch epochs_s[i])."""
        epochs_s = np.asarray(epochs_s, float)
        name = topic_publisher.topic_name.lstrip("/")
        self.scheduled[name] = self.scheduled.get(name, 0) + len(epochs_s)
        self.published.setdefault(name, 0)
        for i, t in enumerate(epochs_s):
            self._queue.append((t + self.latency_s, t, topic_publisher, make_msg, i))
        # only the unreleased tail is ordered (a commanded flight's samples are queued as it is flown)
        self._queue[self._next:] = sorted(self._queue[self._next:], key=lambda e: (e[0], e[1]))

    # ---- a commanded flight (issue 36) -----------------------------------------------
    def follow_flight(self, on_flown):
        """Fly a mirror of the truth node's commanded flight (``flight_mirror``):
        ``on_flown()`` queues the samples of each step as it is flown (with
        ``schedule``); returns the mirror (its ``flight`` is the one to sample).
        The node's stream is complete when ``stream_complete()`` says so."""
        from .flight_mirror import FlightMirror
        self.mirror = FlightMirror(self, self.scenario, lambda: (on_flown(), self._release()))
        return self.mirror

    def stream_complete(self) -> bool:
        """Whether every sample of the stream is queued (a commanded flight's
        node overrides it: its stream grows as the flight is flown)."""
        return True

    def _all_out(self) -> bool:
        return self._next == len(self._queue) and self.stream_complete() and \
            (bool(self._queue) or self.mirror is not None)

    def _start_when_ready(self):
        for entry in self.publishers_to_match():
            pub, need = entry if isinstance(entry, tuple) else \
                (entry, self.waits.get(entry.topic_name.lstrip("/"), self.min_subscribers))
            if pub.get_subscription_count() < need:
                return
        self._wait_timer.cancel()
        self._clock_sub = self.create_subscription(Clock, "/clock", self._on_clock, publisher_qos(1000))

    def _allowance(self) -> float:
        if self._all_out():
            return math.inf                     # the whole stream is out: nothing to hold the clock for
        worked = self.sim_time_s or 0.0
        if self.mirror is not None:             # nothing is known of the flight past the mirror's
            worked = min(worked, self.mirror.flight.flown_s)
        return worked + self.lead_s

    def _on_clock(self, msg: Clock):
        self.sim_time_s = stamp_to_s(msg.clock)
        self._release()

    def _release(self):
        """Publish every queued sample due at the clock received last."""
        if self.sim_time_s is None:
            return
        now = self.sim_time_s
        while self._next < len(self._queue) and self._queue[self._next][0] <= now + 1e-9:
            _, t, pub, make_msg, i = self._queue[self._next]
            pub.publish(make_msg(i))
            name = pub.topic_name.lstrip("/")
            self.published[name] = self.published.get(name, 0) + 1
            self.last_stamp[name] = t
            self._next += 1
        self.allowance.set(self._allowance())
        if self._all_out() and not self._done_reported:
            self._done_reported = True          # the whole stream is out: say so at once
            self.publish_diagnostics()

    def on_shutdown(self):
        """Final /diagnostics on SIGINT/SIGTERM (ros_util.run_node)."""
        self.publish_diagnostics()

    def publish_diagnostics(self):
        values = {f"published {k}": v for k, v in self.published.items()}
        values.update({f"scheduled {k}": v for k, v in self.scheduled.items()})
        values.update({f"last {k}": f"{t:.3f}" for k, t in self.last_stamp.items()})
        values["queued"] = len(self._queue)
        values.update(getattr(self, "_extra_diag", {}))         # a subclass's own counters
        if self.sim_time_s is not None:
            values["sim_time_s"] = f"{self.sim_time_s:.3f}"
        self.status.publish("ok", "done" if self._all_out() else "running", values)

    @staticmethod
    def stamp(msg, t_s: float, frame_id: str):
        msg.header.stamp.sec, msg.header.stamp.nanosec = s_to_stamp_fields(t_s)
        msg.header.frame_id = frame_id
        return msg
