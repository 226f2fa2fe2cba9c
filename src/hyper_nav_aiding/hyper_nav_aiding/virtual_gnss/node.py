"""Virtual GNSS node (seed 004 section 2.3): virtual pseudoranges and rates
of the satellites whose tracking loops lost lock.

Subscribes ``gnss/raw`` (hyper_nav_msgs/GnssMeasurements: the tracking
state), ``gnss/ephemeris`` (hyper_nav_msgs/GnssEphemeris, transient local),
``imu/data_raw`` (sensor_msgs/Imu) and, by ``virtual_gnss.position_source``,
``nav/delayed/state`` (hyper_nav_msgs/NavState, ``fused``) or ``gnss/fix``
(sensor_msgs/NavSatFix, ``alpha_beta``). Publishes
``virtual_gnss.topic`` (default ``gnss/virtual``, GnssMeasurements with
``is_virtual`` and ``locked`` set on every channel, header.stamp = the
receiver epoch) for the fusion node's own declared source, and
``/diagnostics`` (published count, rejected inputs by reason, channels).
All logic is :class:`hyper_nav_aiding.virtual_gnss.core.virtual_gnss.VirtualGnss`;
parameters are declared in :mod:`hyper_nav_aiding.virtual_gnss.parameters`.
"""
from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray
from hyper_nav_msgs.msg import GnssEphemeris, GnssMeasurements
from hyper_nav_msgs.msg import NavState as NavStateMsg
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from sensor_msgs.msg import Imu, NavSatFix

from hyper_nav_filter.clock_gate import ClockAllowance
from hyper_nav_filter.ros_util import all_matched, diagnostic_array, latched_qos, publisher_qos, run_node

from hyper_nav_aiding.virtual_gnss import conversions
from hyper_nav_aiding.virtual_gnss.parameters import VirtualGnssNodeParams, declarations
from hyper_nav_aiding.virtual_gnss.input import VirtualGnssInput


class VirtualGnssNode(Node):
    def __init__(self):
        super().__init__("virtual_gnss")
        values = {name: self.declare_parameter(name, default, ParameterDescriptor(description=desc)).value
                  for name, default, desc in declarations()}
        self.p = VirtualGnssNodeParams.from_values(values)
        self.input = VirtualGnssInput(self.p)
        self.pub = self.create_publisher(GnssMeasurements, self.p.config.topic, publisher_qos(self.p.qos_depth))
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        self.published = 0
        self.allowance = ClockAllowance(self, source=self._allowance)
        self._subs = []
        self._wait = self.create_timer(0.05, self._start_when_ready)
        self.create_timer(1.0, self.publish_diagnostics)

    def _start_when_ready(self):
        """Take inputs once the output has its subscribers (nothing published into the void)."""
        if not all_matched([self.pub], self.p.min_output_subscribers):
            return
        self._wait.cancel()
        qos = publisher_qos(self.p.qos_depth)
        inp = self.input
        self._subs = [self.create_subscription(GnssEphemeris, "gnss/ephemeris",
                                               lambda m: self._warn(inp.on_ephemeris(m)),
                                               latched_qos(max(self.p.qos_depth, 500))),
                      self.create_subscription(GnssMeasurements, "gnss/raw", self._on_raw, qos),
                      self.create_subscription(Imu, "imu/data_raw", lambda m: self._publish(inp.on_imu(m)), qos)]
        if self.p.config.position_source == "fused":
            self._subs.append(self.create_subscription(NavStateMsg, "nav/delayed/state",
                                                    lambda m: self._publish(inp.on_state(m)), qos))
        else:
            self._subs.append(self.create_subscription(NavSatFix, "gnss/fix", inp.on_fix, qos))
        self.get_logger().info("subscribed to " + ", ".join(s.topic_name for s in self._subs))

    def _allowance(self) -> float:
        """The clock may not pass the oldest waiting receiver epoch + clock.deadline_s."""
        t = self.input.core.pending_t_s
        return float("inf") if t is None else t + self.p.clock_deadline_s

    def _warn(self, reason):
        if reason:
            self.get_logger().warn(reason, throttle_duration_sec=5.0)

    def _on_raw(self, msg):
        ready, reason = self.input.on_raw(msg)
        self._warn(reason)
        self._publish(ready)

    def _publish(self, ready):
        for epoch, el, az in ready:
            self.pub.publish(conversions.fill_gnss_measurements(GnssMeasurements(), epoch, el, az, self.p.frame_id))
            self.published += 1

    def publish_diagnostics(self):
        values = {f"received {k}": v for k, v in self.input.received.items()}
        values[f"published {self.p.config.topic}"] = self.published
        values.update(self.input.core.counters)
        err = self.input.core.last_error
        self.pub_diag.publish(diagnostic_array(self, "hyper_nav_aiding: virtual_gnss", not err, err or "ok", values))

    def on_shutdown(self):
        """Final /diagnostics on SIGINT/SIGTERM (ros_util.run_node)."""
        self.publish_diagnostics()


def main(args=None):
    run_node(VirtualGnssNode, args)


if __name__ == "__main__":
    main()
