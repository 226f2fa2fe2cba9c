"""Base class of the clock-driven sensor nodes.

A sensor node loads the scenario, computes its own measurement stream from
the deterministic truth (``hyper_nav_sim.core``), waits until each of its
publishers has ``min_subscribers`` matched subscriptions, then subscribes to
``/clock`` and publishes every sample whose release time (epoch + latency)
has been reached. ``header.stamp`` is always the measurement epoch.
"""
from __future__ import annotations

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from hyper_nav_filter.conversions import s_to_stamp_fields, stamp_to_s
from hyper_nav_filter.ros_util import diagnostic_array, publisher_qos

from ..core.scenario import load_scenario


class ClockDrivenSensor(Node):
    def __init__(self, name: str):
        super().__init__(name)
        self.scenario = load_scenario(self.declare_parameter("scenario", "default").value)
        self.min_subscribers = self.declare_parameter("min_subscribers", 0).value
        self.qos = publisher_qos(self.declare_parameter("qos.depth", self.scenario["graph.qos_depth"]).value)
        self.latency_s = 0.0
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        self.published = {}
        self._queue = []        # list of (release_t_s, epoch_t_s, topic, make_msg)
        self._next = 0
        self._clock_sub = None
        self._wait_timer = self.create_timer(0.05, self._start_when_ready)
        self.create_timer(1.0, self.publish_diagnostics)

    def publishers_to_match(self):
        """Publishers that must see ``min_subscribers`` matched subscriptions
        before data flows; an entry (publisher, n) asks for n instead (for
        topics that other subscribers take, e.g. gnss/raw)."""
        raise NotImplementedError

    def schedule(self, epochs_s, topic_publisher, make_msg):
        """Queue messages: make_msg(i) builds message i (epoch epochs_s[i])."""
        for i, t in enumerate(np.asarray(epochs_s, float)):
            self._queue.append((t + self.latency_s, t, topic_publisher, make_msg, i))
        self._queue.sort(key=lambda e: (e[0], e[1]))

    def _start_when_ready(self):
        for entry in self.publishers_to_match():
            pub, need = entry if isinstance(entry, tuple) else (entry, self.min_subscribers)
            if pub.get_subscription_count() < need:
                return
        self._wait_timer.cancel()
        self._clock_sub = self.create_subscription(Clock, "/clock", self._on_clock, publisher_qos(1000))

    def _on_clock(self, msg: Clock):
        now = stamp_to_s(msg.clock)
        while self._next < len(self._queue) and self._queue[self._next][0] <= now + 1e-9:
            _, t, pub, make_msg, i = self._queue[self._next]
            pub.publish(make_msg(i))
            self.published[pub.topic_name] = self.published.get(pub.topic_name, 0) + 1
            self._next += 1
        if self._next == len(self._queue) and self._queue:
            self.publish_diagnostics()

    def on_shutdown(self):
        """Final /diagnostics on SIGINT/SIGTERM (ros_util.run_node)."""
        self.publish_diagnostics()

    def publish_diagnostics(self):
        values = {f"published {k}": v for k, v in self.published.items()}
        values["queued"] = len(self._queue)
        self.pub_diag.publish(diagnostic_array(self, f"hyper_nav_sim: {self.get_name()}", True,
                                               "done" if self._next == len(self._queue) else "running", values))

    @staticmethod
    def stamp(msg, t_s: float, frame_id: str):
        msg.header.stamp.sec, msg.header.stamp.nanosec = s_to_stamp_fields(t_s)
        msg.header.frame_id = frame_id
        return msg
