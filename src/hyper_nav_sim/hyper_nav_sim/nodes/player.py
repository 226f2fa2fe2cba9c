"""player: replay a rosbag2/MCAP bag, publishing the stored CDR bytes as they are.

Parameters:
    bag (str, required)            bag directory (or a bare .mcap file)
    rate (1.0)                     playback speed factor on log time; <= 0 = as fast
                                   as reliable delivery allows
    publish_clock (true)           publish rosgraph_msgs/Clock on /clock with each
                                   message's log time before it (a recorded /clock
                                   topic is then not replayed)
    wait_for_subscribers (0)       before starting, wait until every replayed topic
                                   has at least this many matched subscriptions ...
    wait_timeout_s (30.0)          ... for at most this long (s), then start anyway
    topics (str[], default [])     topics to replay; empty = all
    qos_depth (2000)               KEEP_LAST depth of the reliable, volatile publishers

A truncated bag is replayed as far as it is readable, with a warning.
"""

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

from hyper_nav_sim.core.bag import read_bag
from hyper_nav_sim.nodes.recorder import message_class, string_array_param

ACK_TIMEOUT = Duration(seconds=10.0)


class Player(Node):
    def __init__(self):
        super().__init__("player")
        bag = self.declare_parameter("bag", "").value
        if not bag:
            raise ValueError("parameter 'bag' is required")
        self.rate = float(self.declare_parameter("rate", 1.0).value)
        publish_clock = self.declare_parameter("publish_clock", True).value
        self.min_subscribers = self.declare_parameter("wait_for_subscribers", 0).value
        self.wait_timeout_s = float(self.declare_parameter("wait_timeout_s", 30.0).value)
        topics = [t if t.startswith("/") else "/" + t for t in string_array_param(self, "topics")]
        depth = self.declare_parameter("qos_depth", 2000).value
        qos = QoSProfile(
            reliability=ReliabilityPolicy.RELIABLE,
            history=HistoryPolicy.KEEP_LAST,
            depth=depth,
            durability=DurabilityPolicy.VOLATILE,
        )
        self.ack_every = max(1, depth // 2)  # wait for acks before the history could overflow
        self.reader = read_bag(bag, topics or None)
        if self.reader.error:
            self.get_logger().warning(f"bag is damaged, replaying what is readable: {self.reader.error}")
        skip = {"/clock"} if publish_clock else set()
        self.pubs = {
            topic: self.create_publisher(message_class(msgtype), topic, qos)
            for topic, msgtype in self.reader.topics.items()
            if topic not in skip
        }
        self.clock_pub = self.create_publisher(Clock, "/clock", qos) if publish_clock else None
        self.replayed = 0

    def wait_for_subscribers(self) -> bool:
        """Block until every publisher has min_subscribers matches (or timeout)."""
        deadline = time.monotonic() + self.wait_timeout_s
        while any(p.get_subscription_count() < self.min_subscribers for p in self.pubs.values()):
            if time.monotonic() > deadline or not rclpy.ok(context=self.context):
                self.get_logger().warning(f"starting without {self.min_subscribers} subscriber(s) on every topic")
                return False
            time.sleep(0.05)
        return True

    def sleep_until(self, wall_s: float) -> None:
        while rclpy.ok(context=self.context) and (left := wall_s - time.monotonic()) > 0:
            time.sleep(min(left, 0.1))

    def wait_acked(self) -> None:
        for pub in [*self.pubs.values(), self.clock_pub]:
            if pub is not None and not pub.wait_for_all_acked(ACK_TIMEOUT):
                self.get_logger().warning(f"{pub.topic_name}: not all messages acknowledged")

    def play(self) -> None:
        """Publish every readable message, paced by log time / rate."""
        t0, wall0 = None, time.monotonic()
        for record in self.reader:
            if not rclpy.ok(context=self.context):
                break
            if record.topic not in self.pubs:
                continue
            t0 = record.t_ns if t0 is None else t0
            if self.rate > 0:
                self.sleep_until(wall0 + (record.t_ns - t0) * 1e-9 / self.rate)
            if self.clock_pub is not None:
                self.clock_pub.publish(Clock(clock=Time(nanoseconds=record.t_ns).to_msg()))
            self.pubs[record.topic].publish(record.raw)
            self.replayed += 1
            if self.replayed % self.ack_every == 0:
                self.wait_acked()
        if rclpy.ok(context=self.context):
            self.wait_acked()  # deliver the tail before the process exits

    def report(self) -> None:
        if self.reader.truncated:
            self.get_logger().warning(f"bag truncated: {self.reader.error}")
        truncated = "yes" if self.reader.truncated else "no"
        self.get_logger().info(f"replayed {self.replayed} messages (truncated: {truncated})")


def main(args=None):
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.ALL)
    node = None
    try:
        node = Player()
        if node.min_subscribers > 0:
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
    main()
