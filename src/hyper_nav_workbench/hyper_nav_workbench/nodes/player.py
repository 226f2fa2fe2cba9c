"""player: replay a rosbag2/MCAP bag, publishing the stored CDR bytes as they are.

Parameters:
    bag (str, required)            bag directory (or a bare .mcap file)
    rate (1.0)                     playback speed factor on log time (> 0); a large factor
                                   with allowance_nodes replays as fast as those nodes keep up
    publish_clock (true)           publish rosgraph_msgs/Clock on /clock with each
                                   message's log time before it (a recorded /clock
                                   topic is then not replayed)
    wait_for_subscribers (0)       before starting, wait until every replayed topic
                                   has at least this many matched subscriptions ...
    wait_topics (str[]), wait_counts (int[])   ... and these topics at least these
                                   counts (per topic, e.g. imu/data_raw: recorder + fusion) ...
    wait_timeout_s (30.0)          ... for at most this long (s), then start anyway
    topics (str[], default [])     topics to replay; empty = all
    qos_depth (2000)               KEEP_LAST depth of the publishers (at least the recorded depth)
    diagnostics_period_s (1.0)     period of the player's /diagnostics status (wall time)
    allowance_nodes (str[], [])    nodes whose /graph/allowance the replay waits for
                                   (hyper_nav_filter.clock_gate): e.g. [fusion], so the
                                   replay never runs ahead of the filter and starts only
                                   once the filter's subscriptions have matched it
                                   (bit-exact live == offline); allowance_timeout_s (10.0)
                                   a silent node is no longer waited for

Each topic is offered with the QoS its publishers offered when it was
recorded (the bag's ``offered_qos_profiles``, adapted as ``ros2 bag play``
does: transient local stays transient local, so e.g. ``gnss/ephemeris``
still reaches a late subscriber); topics recorded without profiles are
reliable and volatile.

Status on /diagnostics ("hyper_nav_sim: player"): ``published <topic>``,
``last <topic>`` and ``sim_time_s`` (log times, sim time for a bag recorded
by run_graph), ``heartbeat``, the bag's ``truncated`` flag (WARN when truncated) and a last
status with ``finished: true``.

A truncated bag is replayed as far as it is readable, with a warning. A bag
that cannot be read at all (no MCAP data, not a bag) ends the player with an
error message naming the file and exit code 2.
"""

import sys
import time

import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time
from rosgraph_msgs.msg import Clock

from hyper_nav_filter.clock_gate import AllowanceGate
from hyper_nav_filter.ros_util import declare_params
from hyper_nav_workbench.core.bag import playback_qos, read_bag
from hyper_nav_sim.nodes.params import PLAYER
from hyper_nav_workbench.nodes.recorder import message_class
from hyper_nav_sim.nodes.status import NodeStatus

ACK_TIMEOUT = Duration(seconds=10.0)


class Player(Node):
    def __init__(self):
        super().__init__("player")
        p = declare_params(self, PLAYER)
        bag = p["bag"]
        if not bag:
            raise ValueError("parameter 'bag' is required")
        self.rate = p["rate"]
        publish_clock = p["publish_clock"]
        self.min_subscribers = p["wait_for_subscribers"]
        wait_topics = [t if t.startswith("/") else "/" + t for t in p["wait_topics"]]
        self.declare_parameter("wait_counts", [0])
        wait_counts = list(self.get_parameter("wait_counts").value) if wait_topics else []
        if len(wait_counts) != len(wait_topics):
            raise ValueError(f"wait_counts {wait_counts} must give one count per wait_topics entry {wait_topics}")
        self.waits = dict(zip(wait_topics, wait_counts))
        self.wait_timeout_s = p["wait_timeout_s"]
        topics = [t if t.startswith("/") else "/" + t for t in p["topics"]]
        depth = p["qos_depth"]
        self.diag_period_s = p["diagnostics_period_s"]
        self.ack_every = max(1, depth // 2)  # wait for acks before the history could overflow
        self.reader = read_bag(bag, topics or None)
        if not self.reader.topics:
            why = f": {self.reader.error}" if self.reader.error else ""
            raise ValueError(f"{bag}: no readable messages{' on ' + str(topics) if topics else ''}{why}")
        if self.reader.error:
            self.get_logger().warning(f"bag is damaged, replaying what is readable: {self.reader.error}")
        skip = {"/clock"} if publish_clock else set()
        self.pubs = {
            topic: self.create_publisher(message_class(msgtype), topic,
                                         recorded_qos(self.reader.qos.get(topic), depth))
            for topic, msgtype in self.reader.topics.items()
            if topic not in skip
        }
        self.clock_pub = self.create_publisher(Clock, "/clock", recorded_qos(None, depth)) if publish_clock else None
        self.replayed = 0
        self.published = {t.lstrip("/"): 0 for t in self.pubs}
        self.last_s: dict[str, float] = {}
        self.now_s = None
        self._waiting = None       # (log time s of the next record, wall time s it is due)
        self.status = NodeStatus(self, "hyper_nav_sim: player")
        self._next_status = 0.0
        # the replayed clock never passes what the waited-for nodes allow (hyper_nav_filter.clock_gate)
        self.gate = AllowanceGate(self, p["allowance_nodes"], p["allowance_timeout_s"])
        self._limit_s = float("-inf")

    def needs_waiting(self) -> bool:
        return self.min_subscribers > 0 or any(n > 0 for n in self.waits.values())

    def wait_for_subscribers(self) -> bool:
        """Block until every publisher has its subscriber count (or timeout)."""
        deadline = time.monotonic() + self.wait_timeout_s

        def missing():
            return [t for t, p in self.pubs.items()
                    if p.get_subscription_count() < max(self.min_subscribers, self.waits.get(t, 0))] + \
                [t for t, n in self.waits.items() if t not in self.pubs and self.count_subscribers(t) < n]
        while (left := missing()):
            self.publish_status()
            if time.monotonic() > deadline or not rclpy.ok(context=self.context):
                self.get_logger().warning(f"starting without all subscribers on {', '.join(left)}")
                return False
            time.sleep(0.05)
        return True

    def sleep_until(self, wall_s: float, next_log_s: float | None = None) -> None:
        self._waiting = None if next_log_s is None else (next_log_s, wall_s)
        while rclpy.ok(context=self.context) and (left := wall_s - time.monotonic()) > 0:
            self.publish_status()
            time.sleep(min(left, 0.1))
        self._waiting = None

    def publish_status(self, finished: bool = False) -> None:
        """Status every diagnostics_period_s of wall time (the player does not
        spin: it publishes from its replay loop)."""
        now = time.monotonic()
        if not finished and now < self._next_status:
            return
        self._next_status = now + self.diag_period_s
        truncated = bool(self.reader.truncated)
        values = {f"published {t}": n for t, n in self.published.items()}
        values.update({f"last {t}": f"{s:.3f}" for t, s in self.last_s.items()})
        if self._waiting is not None and not finished:      # the replayed clock runs on in a hole
            t_next, due = self._waiting
            self.now_s = max(self.now_s or 0.0, t_next - (due - now) * self.rate)
        if self.now_s is not None:
            values["sim_time_s"] = f"{self.now_s:.3f}"
        values["clock_held_s"] = f"{self.gate.held_s:.2f}"
        values["truncated"] = "yes" if truncated else "no"
        if truncated:
            values["bag_error"] = self.reader.error
        message = "done" if finished else "replaying"
        self.status.publish("warn" if truncated else "ok", message + (" (bag truncated)" if truncated else ""),
                            values, finished=finished)

    def wait_acked(self) -> None:
        """Wait (at most ACK_TIMEOUT per topic) until every subscriber acknowledged
        what was published, still publishing the status meanwhile."""
        step = Duration(seconds=0.1)
        for pub in [*self.pubs.values(), self.clock_pub]:
            deadline = time.monotonic() + ACK_TIMEOUT.nanoseconds * 1e-9
            while pub is not None and not pub.wait_for_all_acked(step):
                self.publish_status()
                if time.monotonic() > deadline or not rclpy.ok(context=self.context):
                    self.get_logger().warning(f"{pub.topic_name}: not all messages acknowledged")
                    break

    def wait_for_graph(self, t_s: float) -> float:
        """Hold until the waited-for nodes allow sim time ``t_s`` (the player
        does not spin: it takes their allowances here). Returns the wall
        seconds held, by which the replay's pace is shifted."""
        if not self.gate.expected or t_s <= self._limit_s + 1e-9:
            return 0.0
        t_start = time.monotonic()
        changed, last = t_start, None
        while rclpy.ok(context=self.context):
            rclpy.spin_once(self, timeout_sec=0.0)
            self._limit_s = self.gate.limit_s()
            if t_s <= self._limit_s + 1e-9:
                break
            if self._limit_s != last or not self.gate.all_heard():
                # (a node not heard yet is the gate's first wait, not an allowance that stopped)
                changed, last = time.monotonic(), self._limit_s
            elif time.monotonic() - changed > self.gate.timeout_s:
                # nothing moves the allowance any more (e.g. records past the bag's last IMU sample)
                self.get_logger().warning(f"clock gate: allowance {last:.3f} s unchanged for "
                                          f"{self.gate.timeout_s:g} s at {t_s:.3f} s; no longer waiting")
                self.gate.expected = set()
                break
            self.publish_status()
            rclpy.spin_once(self, timeout_sec=0.02)
        held = time.monotonic() - t_start
        self.gate.held_s += held if held > 0.03 else 0.0
        return held

    def play(self) -> None:
        """Publish every readable message, paced by log time / rate."""
        t0, wall0 = None, time.monotonic()
        self.gate.restart()                    # the waited-for nodes' not-heard timeout counts from here
        self.get_logger().info(f"replaying {len(self.pubs)} topics at {self.rate}x")
        for record in self.reader:
            if not rclpy.ok(context=self.context):
                break
            if record.topic not in self.pubs:
                continue
            t0 = record.t_ns if t0 is None else t0
            wall0 += self.wait_for_graph(record.t_ns * 1e-9)
            if self.rate > 0:
                self.sleep_until(wall0 + (record.t_ns - t0) * 1e-9 / self.rate, record.t_ns * 1e-9)
            if self.clock_pub is not None:
                self.clock_pub.publish(Clock(clock=Time(nanoseconds=record.t_ns).to_msg()))
            self.pubs[record.topic].publish(record.raw)
            self.replayed += 1
            self.published[record.topic.lstrip("/")] += 1
            self.now_s = self.last_s[record.topic.lstrip("/")] = record.t_ns * 1e-9
            self.publish_status()
            if self.replayed % self.ack_every == 0:
                self.wait_acked()
        if rclpy.ok(context=self.context):
            self.get_logger().info(f"replayed {self.replayed} messages; waiting for acknowledgements")
            self.wait_acked()  # deliver the tail before the process exits

    def report(self) -> None:
        if self.reader.truncated:
            self.get_logger().warning(f"bag truncated: {self.reader.error}")
        truncated = "yes" if self.reader.truncated else "no"
        self.get_logger().info(f"replayed {self.replayed} messages (truncated: {truncated})")
        if rclpy.ok(context=self.context):
            self.publish_status(finished=True)
            self.status.pub.wait_for_all_acked(Duration(seconds=0.5))


def recorded_qos(profiles, depth: int) -> QoSProfile:
    """Publisher QoS for a replayed topic from its recorded offered profiles
    (:func:`hyper_nav_workbench.core.bag.playback_qos`)."""
    q = playback_qos(profiles)
    return QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE if q["reliability"] == "reliable" else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if q["durability"] == "transient_local"
        else DurabilityPolicy.VOLATILE,
        history=HistoryPolicy.KEEP_LAST, depth=max(int(depth), q["depth"]))


def main(args=None):
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.ALL)
    node = None
    try:
        try:
            node = Player()
        except (OSError, ValueError) as exc:   # unreadable bag, missing parameter: a message, not a traceback
            print(f"player: error: {exc}", file=sys.stderr, flush=True)
            return 2
        if node.needs_waiting():
            node.wait_for_subscribers()
        node.play()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except _rclpy.RCLError:
        if rclpy.ok():  # not a publish racing a SIGINT/SIGTERM shutdown
            raise
    finally:
        if node is not None:
            node.report()
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
