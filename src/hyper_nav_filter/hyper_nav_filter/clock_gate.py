"""The simulated clock waits for the graph (lockstep under load).

A graph paced only by the wall clock loses data or delivers it late when the
machine is loaded: a slow subscriber falls behind its publishers' queues, a
slow aiding node's output reaches the filter after its epoch was released.
Here every node whose lag matters publishes an *allowance* on
``/graph/allowance`` (``diagnostic_msgs/KeyValue``: key = node name, value =
the latest sim time, s, the clock may reach while this node keeps up; "inf"
when it is not behind), and the time source (truth node or player) never
advances the clock past the smallest allowance of the nodes it was told to
wait for (``AllowanceGate``). So on a loaded machine the simulation runs
slower in wall time, and what it computes is the same.

What the nodes allow (README, Timing):

* fusion: its newest IMU epoch + ``clock.lead_s`` (it never lags further);
  the ``/clock`` it took + ``clock.lead_s`` once that is ``clock.imu_gap_s``
  past its newest IMU (a gap in the IMU data: nothing to wait for);
* recorder: the header stamp of the newest IMU message it wrote +
  ``clock.lead_s`` (``hyper_nav_sim/core/record_pace.py``; its node clock is
  the newest ``/clock``, which says nothing of its queues), its node clock +
  ``clock.lead_s`` while the IMU stream is silent;
* aiding nodes with an output pending for an epoch t (a geomagnetic fix, a
  virtual GNSS epoch, a learned model update stamped t): t +
  ``clock.deadline_s`` (the fusion node's ``output_delay_s`` minus a margin),
  so the output reaches the filter before the filter releases t.

A node that stops reporting (dead, hung) for ``timeout_s`` of wall time is
no longer waited for (the liveness monitor reports it), so the clock never
stalls forever.

A node publishes no allowance at all until its inputs are matched from its
own side (``ClockAllowance(ready=InputsReady(...))``): the time source's
publisher counts a subscription as matched once *it* has discovered it, and
starts sending; the subscriber may discover that publisher later, and a
volatile reliable reader drops what a writer sent before the reader matched
it. While the gate has not heard a node it holds the clock, up to its
``first_timeout_s`` (60 s; ``timeout_s`` is for a node that went silent)
counted from the start of the flight or replay (``AllowanceGate.restart``),
so nothing is sent before the subscriber is ready (issue 22,
docs/faults-and-timing.md).
"""
from __future__ import annotations

import math
import time

from diagnostic_msgs.msg import KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

TOPIC = "/graph/allowance"
_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)


class ClockAllowance:
    """A node's side: ``set(allow_s)`` whenever it changes; it is published
    at once when it shrinks or has grown by ``step_s``, and on a wall-clock
    timer (``period_s``) always, which also tells the gate the node is alive."""

    def __init__(self, node, period_s: float = 0.05, step_s: float = 0.1, source=None, ready=None):
        """``source``: a callable giving the allowance, evaluated on the timer
        (instead of ``set``). ``ready``: a callable; nothing is published
        until it first returns True (e.g. ``InputsReady``)."""
        self.node = node
        self.ready = ready
        self.pub = node.create_publisher(KeyValue, TOPIC, _QOS)
        self.allow_s = math.inf
        self.step_s = float(step_s)
        self.source = source
        self._sent = None
        # a wall-clock (steady) timer: with use_sim_time a sim-time timer would wait for the very
        # /clock this allowance lets the time source publish (a deadlock until the gate's timeout)
        node.create_timer(period_s, self._tick, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _tick(self) -> None:
        if self.source is not None:
            self.allow_s = float(self.source())
        self._publish()

    def set(self, allow_s: float) -> None:
        allow_s = float(allow_s)
        sent = self._sent
        self.allow_s = allow_s
        if sent is None or allow_s < sent or (allow_s >= sent + self.step_s):
            self._publish()

    def _publish(self) -> None:
        if self.ready is not None:
            if not self.ready():
                return
            self.ready = None                  # once ready, always
        self.pub.publish(KeyValue(key=self.node.get_name(), value=repr(self.allow_s)))
        self._sent = self.allow_s


class InputsReady:
    """Whether a node's input subscriptions are matched from the node's own
    side: each has matched as many publishers as the graph shows on its
    topic, and each of ``required`` (topic names) at least one. Until the
    subscriptions exist (``subscriptions()`` empty) it is not ready; after
    ``timeout_s`` of wall time from then it is, with a warning naming the
    topics still unmatched (a publisher with incompatible QoS never matches),
    so a gate is never held for good."""

    def __init__(self, node, subscriptions, required=(), timeout_s: float = 20.0):
        """``subscriptions``: a callable returning the node's input
        subscriptions (rclpy ``Subscription``), which may be created later."""
        self.node = node
        self.subscriptions = subscriptions
        self.required = {node.resolve_topic_name(t) for t in required}
        self.timeout_s = float(timeout_s)
        self._since = None

    def unmatched(self) -> list[str]:
        """Input topics not matched yet from this side (empty: ready)."""
        out = []
        for sub in self.subscriptions():
            topic = sub.topic_name
            known = self.node.count_publishers(topic)
            matched = sub.get_publisher_count()
            if matched < known or (topic in self.required and matched < 1):
                out.append(f"{topic} ({matched} of {max(known, 1)} publishers matched)")
        return out

    def __call__(self) -> bool:
        subs = self.subscriptions()
        if not subs:
            return False
        if self._since is None:
            self._since = time.monotonic()
        left = self.unmatched()
        if not left:
            return True
        if time.monotonic() - self._since > self.timeout_s:
            self.node.get_logger().warning(f"inputs not matched after {self.timeout_s:g} s: {', '.join(left)}; "
                                           "allowing the clock anyway")
            return True
        return False


class AllowanceGate:
    """The time source's side: the clock limit from the allowances of the
    ``expected`` nodes (names). A node silent for ``timeout_s`` of wall time
    after it was heard, or not heard from at all ``first_timeout_s`` after
    the gate's (re)start, counts as not waited for (``dropped``). The first
    wait is the longer one: a node not heard yet is still starting (imports,
    its subscriptions matching from its side, ``InputsReady``), and a time
    source that runs free past it sends its first messages to subscriptions
    that may not have matched yet: lost."""

    def __init__(self, node, expected, timeout_s: float = 10.0, first_timeout_s: float = 60.0):
        self.node = node
        self.expected = set(expected)
        self.timeout_s = float(timeout_s)
        self.first_timeout_s = max(float(first_timeout_s), self.timeout_s)
        self.t0 = time.monotonic()
        self.allow: dict[str, tuple[float, float]] = {}    # name -> (allow_s, wall time heard)
        self.held_s = 0.0                                  # wall time the clock waited for the graph
        self.dropped: set[str] = set()
        if self.expected:
            node.create_subscription(KeyValue, TOPIC, self._on, _QOS)

    def restart(self) -> None:
        """Count the not-heard-yet timeout from now: call it when the time
        source starts (after waiting for its subscribers), so a node that
        took long to start (loaded machine: its subscriptions, its inputs'
        matching) is not dropped before the first message is due (ci14: a
        player dropped the fusion node while waiting for its subscribers,
        ran free and the node lost the first 0.8 s)."""
        self.t0 = time.monotonic()

    def _on(self, msg) -> None:
        if msg.key in self.expected:
            try:
                self.allow[msg.key] = (float(msg.value), time.monotonic())
            except ValueError:
                pass

    def limit_s(self) -> float:
        """The latest sim time the clock may reach now."""
        now = time.monotonic()
        lim = math.inf
        for name in self.expected:
            a = self.allow.get(name)
            if a is None:
                if now - self.t0 < self.first_timeout_s:
                    lim = min(lim, 0.0)
                else:
                    self._drop(name, "never heard")
            elif now - a[1] > self.timeout_s:
                self._drop(name, "silent")
            else:
                lim = min(lim, a[0])
        return lim

    def all_heard(self) -> bool:
        """Whether every expected node has sent an allowance or been dropped."""
        return all(n in self.allow or n in self.dropped for n in self.expected)

    def _drop(self, name: str, why: str) -> None:
        if name not in self.dropped:
            t = self.first_timeout_s if why == "never heard" else self.timeout_s
            self.node.get_logger().warning(f"clock gate: {name} {why} for {t:g} s (wall); "
                                           "not waiting for it while it stays so")
        self.dropped.add(name)
