"""fix_relay_node: subscribes ``gnss/fix`` (sensor_msgs/NavSatFix), publishes
each fix on ``fix_relay.topic`` with its covariance scaled by
``fix_relay.sigma_scale``^2, once the output has ``min_output_subscribers``;
``/diagnostics`` counts what it received and published."""
from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from sensor_msgs.msg import NavSatFix

from hyper_nav_filter.ros_util import all_matched, diagnostic_array, publisher_qos, run_node

from .descriptor import FixRelayConfig

PARAMETERS = [("fix_relay.topic", "relay/fix", "output topic (sensor_msgs/NavSatFix)"),
              ("fix_relay.sigma_scale", 1.0, "the relayed fixes' 1-sigma = the receiver's x this"),
              ("qos.depth", 2000, "publisher and subscriber queue depth"),
              ("min_output_subscribers", 0, "subscriptions the output must see before gnss/fix is taken"),
              ("diagnostics_period_s", 1.0, "period of /diagnostics")]


class FixRelayNode(Node):
    def __init__(self):
        super().__init__("fix_relay")
        p = {name: self.declare_parameter(name, default, ParameterDescriptor(description=desc)).value
             for name, default, desc in PARAMETERS}
        self.cfg = FixRelayConfig.from_block({"topic": p["fix_relay.topic"], "sigma_scale": p["fix_relay.sigma_scale"]})
        self.p = p
        self.pub = self.create_publisher(NavSatFix, self.cfg.topic, publisher_qos(p["qos.depth"]))
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        self.received = self.published = 0
        self._sub = None
        self._wait = self.create_timer(0.05, self._start_when_ready)
        self.create_timer(p["diagnostics_period_s"], self.publish_diagnostics)

    def _start_when_ready(self):
        if not all_matched([self.pub], self.p["min_output_subscribers"]):
            return
        self._wait.cancel()
        self._sub = self.create_subscription(NavSatFix, "gnss/fix", self._on_fix, publisher_qos(self.p["qos.depth"]))

    def _on_fix(self, msg):
        self.received += 1
        k = self.cfg.sigma_scale ** 2
        msg.position_covariance = [float(c) * k for c in msg.position_covariance]
        self.pub.publish(msg)
        self.published += 1

    def publish_diagnostics(self):
        values = {"received gnss/fix": self.received, f"published {self.cfg.topic}": self.published}
        self.pub_diag.publish(diagnostic_array(self, "hyper_nav_fix_relay: fix_relay", True, "ok", values))

    def on_shutdown(self):
        self.publish_diagnostics()


def main(args=None):
    run_node(FixRelayNode, args)


if __name__ == "__main__":
    main()
