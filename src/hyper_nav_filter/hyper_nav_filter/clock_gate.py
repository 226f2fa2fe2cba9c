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
  past its newest IMU (a gap in the IMU data: nothing to wait for); and never
  more than the ``/clock`` at which it last found every declared input's
  queue empty + ``clock.lead_s`` (``InputsIdle``: seen through a wait set of
  its own, nothing taken, so its executor's order of processing stays);
* recorder: the node clock at which it last found *every* recorded topic's
  queue empty + ``clock.lead_s`` (``InputDrain``: each pass takes all that is
  queued on every subscription; the rule covers any stream, so adding one
  cannot reopen a hole. It followed the newest IMU stamp written until
  issue 33: the 400 Hz ``imu/load`` stream was not in it);
* sensor nodes (the producers): the ``/clock`` they have worked through +
  ``clock.lead_s`` (inf once their whole stream is out), so a sensor node
  that is starved or frozen holds the clock instead of releasing, when it
  resumes, a burst of seconds of data deeper than its consumers' queues
  (issue 33: the IMU node frozen 5 s lost 354 ``imu/load`` messages at the
  recorder);
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

import contextlib
import math
import time

from diagnostic_msgs.msg import KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidHandle
from rclpy.subscription import Subscription
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


class DrainPace:
    """The back-pressure rule of a consumer, pure (no rclpy): the clock may
    run ``lead_s`` ahead of the node clock at which the node last found every
    input queue empty (``drained(clock_s)`` after such a pass). A backlog on
    any input, of any rate, holds it; a node whose queues are all empty
    allows its clock + ``lead_s``. Before the first pass: the clock +
    ``lead_s`` (nothing received yet, nothing queued)."""

    def __init__(self, lead_s: float):
        self.lead_s = float(lead_s)
        self.clock_s: float | None = None

    def drained(self, clock_s: float) -> None:
        self.clock_s = clock_s if self.clock_s is None else max(self.clock_s, clock_s)

    def allowance_s(self, clock_s: float) -> float:
        return (clock_s if self.clock_s is None else self.clock_s) + self.lead_s


class InputDrain:
    """Take everything queued on a node's input subscriptions, and know the
    node clock at which all of them were last found empty (``pace``).

    The rclpy executor takes *one* message per ready subscription per wait:
    a node that is short of CPU then takes its 400 Hz stream at the rate of
    its 50 Hz one, and the fast stream's queue (KEEP_LAST) overflows while
    the slow one looks current. ``drain()`` takes each subscription until it
    is empty (at most ``max_per_topic`` per pass, so timers still run; a
    pass cut short proves nothing and leaves ``pace`` as it was), calling
    its callback, and records the node clock read at the start of a pass
    that emptied them all: every message queued then has been taken.

    Call it from the node's own executor thread (a timer, a callback, the
    spin loop): it runs callbacks. Re-entrant calls return at once."""

    def __init__(self, node, subscriptions, lead_s: float, max_per_topic: int = 2000, clock_s=None):
        """``subscriptions``: a callable returning the input subscriptions
        (rclpy ``Subscription``; they may be created later). ``clock_s``: a
        callable giving the node's sim time (default: the node clock)."""
        self.node = node
        self.subscriptions = subscriptions
        self._clock_s = clock_s
        self.pace = DrainPace(lead_s)
        self.max_per_topic = int(max_per_topic)
        self.taken = 0                    # messages taken by drain() (beside those the executor took)
        self.passes = 0
        self.cut_short = 0                # passes that hit max_per_topic on some subscription
        self._busy = False

    def now_s(self) -> float:
        if self._clock_s is not None:
            return float(self._clock_s())
        return self.node.get_clock().now().nanoseconds * 1e-9

    def drain(self) -> int:
        """One pass over every subscription; the number of messages taken."""
        if self._busy:
            return 0
        self._busy = True
        try:
            clock_s, n, empty = self.now_s(), 0, True
            for sub in list(self.subscriptions()):
                k = 0
                while k < self.max_per_topic:
                    try:
                        with sub.handle:
                            info = sub.handle.take_message(sub.msg_type, sub.raw)
                    except InvalidHandle:            # destroyed meanwhile
                        break
                    if info is None:
                        break
                    k += 1
                    if sub._callback_type is Subscription.CallbackType.MessageOnly:
                        sub.callback(info[0])
                    else:
                        sub.callback(*info)
                else:
                    empty = False
                n += k
            self.taken += n
            self.passes += 1
            if empty:
                self.pace.drained(clock_s)
            else:
                self.cut_short += 1
            return n
        finally:
            self._busy = False

    def allowance_s(self) -> float:
        """Drain, then the clock limit this node allows (``DrainPace``)."""
        self.drain()
        return self.pace.allowance_s(self.now_s())


class InputsIdle:
    """The same rule as ``InputDrain`` without taking anything (the node's
    executor keeps its own order of processing): ``check()`` asks, through a
    wait set of its own with a zero timeout, whether any input subscription
    has a message queued; when none has, every message that arrived has been
    taken and processed (single-threaded executor), and ``pace`` records the
    node's sim time. A node that never gets a moment with every queue empty
    (short of CPU, a backlog on any input) holds the clock at the last one +
    ``lead_s``. Before the subscriptions exist, and before the clock runs,
    it allows anything (nothing can be queued)."""

    def __init__(self, node, subscriptions, lead_s: float, clock_s):
        """``subscriptions``: a callable returning the input subscriptions;
        ``clock_s``: a callable giving the node's sim time (s)."""
        from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
        self._rclpy = _rclpy
        self.node = node
        self.subscriptions = subscriptions
        self.clock_s = clock_s
        self.pace = DrainPace(lead_s)
        self.checks = 0
        self.idle = 0
        self._ws = None

    def check(self) -> bool:
        """Whether every input queue is empty now (then ``pace`` moves on)."""
        subs = list(self.subscriptions())
        clock_s = float(self.clock_s())
        if not subs or not math.isfinite(clock_s):
            return False
        self.checks += 1
        with contextlib.ExitStack() as stack:
            for sub in subs:
                stack.enter_context(sub.handle)
            stack.enter_context(self.node.context.handle)
            if self._ws is None or self._ws[0] != subs:      # one wait set while the inputs stay the same
                self._ws = (subs, self._rclpy.WaitSet(len(subs), 0, 0, 0, 0, 0, self.node.context.handle))
            ws = self._ws[1]
            ws.clear_entities()
            for sub in subs:
                ws.add_subscription(sub.handle)
            ws.wait(0)
            ready = ws.get_ready_entities("subscription")
        if ready:
            return False
        self.idle += 1
        self.pace.drained(clock_s)
        return True

    def allowance_s(self) -> float:
        """The clock limit for the inputs (inf before anything can be queued)."""
        clock_s = float(self.clock_s())
        if self.pace.clock_s is None and (not self.subscriptions() or not math.isfinite(clock_s)):
            return math.inf
        return self.pace.allowance_s(clock_s)
