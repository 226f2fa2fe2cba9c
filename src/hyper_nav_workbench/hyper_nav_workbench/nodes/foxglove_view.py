"""foxglove_view: the running graph in the Foxglove app (off by default;
``run_graph --foxglove`` starts it). Subscribes ``truth/state``,
``nav/state``, ``gnss/fix``, ``/tf`` and ``/tf_static`` and serves them over
WebSocket (foxglove-sdk, ``hyper_nav_workbench.foxglove_view`` says which channel
goes to which panel). Binds to 127.0.0.1 unless ``host`` says otherwise.
It never holds the graph back: publishers do not wait for it.

With ``--bag`` it serves (or writes) a recorded run instead, no ROS needed.
"""
from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from hyper_nav_msgs.msg import NavState
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import NavSatFix
from tf2_msgs.msg import TFMessage

from hyper_nav_filter.core.params import FLOAT, INT, STR, ParamSpec, nonneg
from hyper_nav_filter.ros_util import declare_params, diagnostic_array, publisher_qos, run_node

from hyper_nav_workbench.foxglove_view import FoxgloveSink

PARAMS = (
    ParamSpec("host", STR, "127.0.0.1", "address the WebSocket server binds to (localhost only by default)"),
    ParamSpec("port", INT, 8765, "WebSocket port (0 = any free port, reported on /diagnostics)", lo=0, hi=65535),
    nonneg("map_rate_hz", FLOAT, 10.0, "map points per second per track (0 = every message)"),
    ParamSpec("qos_depth", INT, 2000, "subscription depth", lo=1, hi=100000),
)


class FoxgloveViewNode(Node):
    def __init__(self):
        super().__init__("foxglove_view")
        self.p = declare_params(self, PARAMS)
        self.sink = FoxgloveSink(server=True, host=self.p["host"], port=self.p["port"],
                                 map_rate_hz=self.p["map_rate_hz"])
        qos = publisher_qos(self.p["qos_depth"])
        latched = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.create_subscription(NavState, "truth/state", self.sink.on_truth, qos)
        self.create_subscription(NavState, "nav/state", self.sink.on_nav, qos)              # current time
        self.create_subscription(NavState, "nav/delayed/state", self.sink.on_nav_delayed, qos)  # the record
        self.create_subscription(NavSatFix, "gnss/fix", self.sink.on_gnss, qos)
        self.create_subscription(TFMessage, "/tf", self.sink.on_tf, qos)
        self.create_subscription(TFMessage, "/tf_static", self.sink.on_tf, latched)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        self._heartbeat = 0
        self.create_timer(1.0, self._diag)
        self.get_logger().info(f"Foxglove WebSocket on ws://{self.p['host']}:{self.sink.port}")

    def _diag(self):
        self._heartbeat += 1               # the monitor's liveness (graph node "foxglove")
        values = {"port": self.sink.port, "heartbeat": self._heartbeat,
                  **{f"logged {k}": v for k, v in self.sink.counts.items()}}
        self.pub_diag.publish(diagnostic_array(self, "hyper_nav_sim: foxglove_view", True,
                                               f"serving ws://{self.p['host']}:{self.sink.port}", values))

    def on_shutdown(self):
        self._diag()
        self.sink.close()


def main(args=None):
    argv = sys.argv[1:] if args is None else list(args)
    if "--bag" in argv:
        from hyper_nav_workbench.foxglove_view import main as bag_main
        return bag_main(argv)
    run_node(FoxgloveViewNode, args)


if __name__ == "__main__":
    sys.exit(main())
