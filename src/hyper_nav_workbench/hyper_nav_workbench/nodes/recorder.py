"""recorder: record ROS topics into a rosbag2/MCAP bag as raw CDR (no deserialization).

Parameters:
    output (str, required)       bag directory to create; must not exist
    topics (str[], default [])   topics to record; empty = every topic discovered
    discovery_period_s (0.2)     how often to look for new topics (s)
    qos_depth (2000)             KEEP_LAST depth of the reliable, volatile subscriptions

Log time of each message = receive time on the node clock (ns; /clock time with
use_sim_time:=true, as run_graph starts it: the bag's timeline is then sim time,
and the player replays it on sim time). /rosout and /parameter_events are never recorded.
A topic is recorded once it has a publisher: the publishers' offered QoS
profiles go into the bag (``offered_qos_profiles``, as rosbag2 records them)
and the subscription adapts to them as ``ros2 bag record`` does (reliable if
every publisher is reliable, transient local if every one is, e.g.
``gnss/ephemeris``, so its history is recorded even if it was published
before the recorder subscribed).
Publishes the per-topic counts every second on /recorder/counts
(diagnostic_msgs/DiagnosticArray, status "recorder", key=topic, value=count)
and its status with a ``heartbeat`` on /diagnostics ("hyper_nav_sim: recorder",
``recorded <topic>``) every ``diagnostics_period_s`` (1.0 s).

Nothing is lost silently: a topic with one publisher (never more) carries
the writer's sequence number with each message (``publication_sequence_number``); a jump
is a message that never reached the bag (the subscription's queue overflowed,
a writer's history overwrote it). It is counted per topic (``lost <topic>``
on /diagnostics and /recorder/counts, the status then ERROR, so the report
fails) and printed when the bag is closed. (A loss before a topic's first
recorded message or after its last leaves no gap to see: the report's check
of every publisher's count against the bag covers those.)

The clock allowance (``hyper_nav_filter.clock_gate.InputDrain``): every
queue is taken whole in each pass, and the clock may run ``clock.lead_s``
ahead of the node clock at which all of them were last found empty.
    drain_quiet_s (0.5), drain_max_s (10.0)   on SIGINT/SIGTERM, keep taking messages
                                 until none arrived for drain_quiet_s (at most drain_max_s)

SIGINT/SIGTERM stop the recording after that drain, so what the other nodes
published just before they stopped is still in the bag, and close the bag
cleanly (MCAP summary and metadata.yaml written).
"""

import importlib
import signal
import threading
import time
from functools import partial

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from hyper_nav_filter.clock_gate import TOPIC as ALLOWANCE_TOPIC
from hyper_nav_filter.clock_gate import ClockAllowance, InputDrain
from hyper_nav_filter.ros_util import declare_params
from hyper_nav_workbench.core.bag import INFINITE, BagWriter, playback_qos, qos_profile, typestore
from hyper_nav_sim.nodes.params import RECORDER
from hyper_nav_sim.nodes.status import NodeStatus

NEVER_RECORD = frozenset({"/rosout", "/parameter_events", ALLOWANCE_TOPIC})


def message_class(msgtype: str):
    """Generated Python class of a ROS type name such as 'sensor_msgs/msg/Imu'."""
    try:
        from rosidl_runtime_py.utilities import get_message
    except ImportError:
        pkg, _, name = msgtype.split("/")
        return getattr(importlib.import_module(f"{pkg}.msg"), name)
    return get_message(msgtype)


class Recorder(Node):
    def __init__(self):
        super().__init__("recorder")
        self.p = p = declare_params(self, RECORDER)
        output = p["output"]
        if not output:
            raise ValueError("parameter 'output' (bag directory) is required")
        self.wanted = {t if t.startswith("/") else "/" + t for t in p["topics"]}
        period = p["discovery_period_s"]
        self.depth = p["qos_depth"]
        self.bag = BagWriter(output)
        self.subs = {}  # topic -> subscription (None: not recordable)
        self.lost: dict[str, int] = {}       # topic -> messages that never reached the bag (sequence gaps)
        self._seq: dict[str, int] = {}       # topic -> the last publication sequence number taken
        self._multi: set[str] = set()        # topics seen with several publishers (sequences interleave)
        self.counts_pub = self.create_publisher(DiagnosticArray, "/recorder/counts", 10)
        # the clock waits for this recorder: the node clock at which it last found every recorded topic's
        # queue empty + clock.lead_s (clock_gate.InputDrain: any stream, whatever its rate; its node clock
        # alone is the newest /clock, not how far it has worked through its queues)
        self.drain = InputDrain(self, lambda: [s for s in self.subs.values() if s is not None],
                                p["clock.lead_s"], max_per_topic=self.depth)
        self.allowance = ClockAllowance(self, source=self.drain.allowance_s)
        self.status = NodeStatus(self, "hyper_nav_sim: recorder")
        # wall-clock timers: with use_sim_time the node clock stands still until /clock starts
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(period, self.discover, clock=wall)
        self.create_timer(1.0, self.publish_counts, clock=wall)
        self.create_timer(p["diagnostics_period_s"], self.publish_status, clock=wall)
        self.get_logger().info(f"recording into {output}")

    @property
    def counts(self) -> dict:
        """Messages recorded per topic."""
        return self.bag.counts

    def discover(self):
        for topic, types in self.get_topic_names_and_types():
            if topic in self.subs or topic in NEVER_RECORD or (self.wanted and topic not in self.wanted):
                continue
            offered = [offered_profile(info.qos_profile) for info in self.get_publishers_info_by_topic(topic)]
            if not offered:
                continue            # no publisher (yet): rosbag2 records topics that have one
            msgtype, self.subs[topic] = types[0], None
            if msgtype not in typestore().types:
                self.get_logger().warning(f"not recording {topic}: type {msgtype} unknown to the typestore")
                continue
            try:
                cls = message_class(msgtype)
            except (ImportError, AttributeError, ValueError) as exc:
                self.get_logger().warning(f"not recording {topic}: {exc}")
                continue
            callback = partial(self.on_message, topic, msgtype)
            adapted = playback_qos(offered)
            qos = QoSProfile(
                reliability=ReliabilityPolicy.RELIABLE if adapted["reliability"] == "reliable"
                else ReliabilityPolicy.BEST_EFFORT,
                durability=DurabilityPolicy.TRANSIENT_LOCAL if adapted["durability"] == "transient_local"
                else DurabilityPolicy.VOLATILE,
                history=HistoryPolicy.KEEP_LAST, depth=max(self.depth, adapted["depth"]))
            self.bag.add_topic(topic, msgtype, offered)
            self.subs[topic] = self.create_subscription(cls, topic, callback, qos, raw=True)
            self.get_logger().info(f"recording {topic} [{msgtype}] ({adapted['reliability']}, "
                                   f"{adapted['durability']})")

    def on_message(self, topic: str, msgtype: str, raw: bytes, info: dict):
        self.bag.write(topic, msgtype, self.get_clock().now().nanoseconds, raw)
        seq = info.get("publication_sequence_number", 0) if info else 0
        if seq <= 0:                           # (an rmw without sequence numbers: 0 or max uint64)
            return
        if topic in self._multi:
            return
        if self.subs[topic].get_publisher_count() > 1:   # a message carries no writer id: one writer only
            self._multi.add(topic)
            return
        last = self._seq.get(topic)
        self._seq[topic] = seq
        if last is not None and seq > last + 1:
            gap = seq - last - 1
            if gap < 2**32:                    # not an rmw's "unsupported" value
                self.lost[topic] = self.lost.get(topic, 0) + gap
                self.get_logger().error(f"{topic}: {gap} message(s) lost before the bag (sequence "
                                        f"{last} -> {seq}); {self.lost[topic]} so far")

    def publish_counts(self):
        status = DiagnosticStatus(level=DiagnosticStatus.OK, name="recorder")
        status.message = f"{sum(self.counts.values())} messages"
        status.values = [KeyValue(key=t, value=str(n)) for t, n in sorted(self.counts.items())]
        status.values += [KeyValue(key=f"lost {t}", value=str(n)) for t, n in sorted(self.lost.items())]
        if self.lost:
            status.level = DiagnosticStatus.ERROR
            status.message += f", {sum(self.lost.values())} lost"
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        self.counts_pub.publish(msg)
        self.bag.flush()

    def publish_status(self, finished: bool = False):
        values = {f"recorded {t.lstrip('/')}": n for t, n in self.counts.items()}
        values.update({f"lost {t.lstrip('/')}": n for t, n in self.lost.items()})
        values.update(drain_passes=self.drain.passes, drain_cut_short=self.drain.cut_short)
        lost = sum(self.lost.values())
        self.status.publish("error" if lost else "ok", f"{sum(self.counts.values())} messages" +
                            (f", {lost} LOST before the bag ({', '.join(sorted(self.lost))})" if lost else ""),
                            values, finished=finished)

    def close(self):
        """Finish the bag (metadata.yaml) and print the per-topic counts."""
        self.bag.close()
        print(f"recorder: closed {self.bag.path}", flush=True)
        for topic, n in sorted(self.counts.items()):
            print(f"  {topic}: {n}" + (f" ({self.lost[topic]} LOST)" if self.lost.get(topic) else ""), flush=True)


def offered_profile(qos) -> dict:
    """An rclpy QoSProfile (as graph introspection reports a publisher's) ->
    the rosbag2 metadata form (:func:`hyper_nav_workbench.core.bag.qos_profile`)."""
    def duration(d):
        ns = int(getattr(d, "nanoseconds", 0))
        return dict(INFINITE) if ns <= 0 or ns >= 2**63 - 1 else {"sec": ns // 10**9, "nsec": ns % 10**9}
    return qos_profile(reliability=qos.reliability.name.lower(), durability=qos.durability.name.lower(),
                       history=qos.history.name.lower(), depth=int(qos.depth), deadline=duration(qos.deadline),
                       lifespan=duration(qos.lifespan), liveliness=qos.liveliness.name.lower(),
                       liveliness_lease_duration=duration(qos.liveliness_lease_duration),
                       avoid_ros_namespace_conventions=bool(qos.avoid_ros_namespace_conventions))


def main(args=None):
    # Our own SIGINT/SIGTERM handling: rclpy's would shut the context down at
    # once (losing the messages still in flight, and racing the executor's
    # wait set: "context is not valid" on exit). The signal only sets a flag;
    # the loop then drains and closes the bag.
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    node = None
    try:
        node = Recorder()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.1)
            node.drain.drain()              # the rest of every queue (one message per topic per wait otherwise)
        quiet_s = node.p["drain_quiet_s"]
        deadline = time.monotonic() + node.p["drain_max_s"]
        last, quiet_since = -1, time.monotonic()
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
            node.drain.drain()
            total = sum(node.counts.values())
            if total != last:
                last, quiet_since = total, time.monotonic()
            elif time.monotonic() - quiet_since >= quiet_s:
                break
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.publish_status(finished=True)
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
