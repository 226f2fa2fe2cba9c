"""Guidance node: flies the glide to the scenario's target on a navigation stream.

Subscribes ``nav_topic`` (``guidance.nav_topic``, default ``nav/odom``,
``nav_msgs/Odometry`` in the fusion node's map frame; ``nav_type: navstate``
for ``hyper_nav_msgs/NavState`` topics such as ``nav/state`` or
``truth/state``; remappable), computes one command per navigation stamp on
the guidance grid (t = j guidance.period_s, t >= guidance.t_start_s) with
``core.law.GlideGuidance``, and publishes it on ``command_topic``
(``hyper_nav_msgs/GlideCommand``, stamped with the navigation stamp; the
truth node applies it at the declared step). Messages off the grid are
skipped; NaN, out-of-order or repeated stamps are rejected and counted on
/diagnostics. The node keeps no sim-time timer: the same navigation
messages give the same commands, live or offline. It reports to the clock
gate (``/graph/allowance``) once its navigation subscription is matched, so
the time source sends nothing it would miss.
"""
from __future__ import annotations

import math

from hyper_nav_msgs.msg import GlideCommand, NavState
from nav_msgs.msg import Odometry
from rclpy.node import Node

from hyper_nav_filter.clock_gate import ClockAllowance, InputsReady
from hyper_nav_filter.conversions import s_to_stamp_fields, stamp_to_s
from hyper_nav_filter.ros_util import all_matched, publisher_qos, run_node
from hyper_nav_sim.core.boost_glide_config import parse_flight
from hyper_nav_sim.core.guidance_config import GuidanceConfig
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_sim.nodes.status import NodeStatus

from ..core.law import GlideGuidance
from ..core.nav_input import finite, odometry_to_geodetic


class GuidanceNode(Node):
    def __init__(self, **node_kw):
        super().__init__("guidance", **node_kw)
        self.declare_parameter("scenario", "default")
        sc = load_scenario(self.get_parameter("scenario").value)
        if "guidance" not in sc.data or "flight" not in sc.data:
            raise ValueError(f"scenario {sc.name}: the guidance node needs a guidance: and a flight: block")
        cfg = self.cfg = GuidanceConfig.from_config(sc.data["guidance"])
        self.declare_parameter("nav_topic", cfg.nav_topic)
        self.declare_parameter("nav_type", cfg.nav_type)
        self.declare_parameter("diagnostics_period_s", float(sc["graph.diagnostics_period_s"]))
        # the command topic's subscribers (the truth node, a recorder, a test's collector) matched from this
        # side before the clock runs: a reliable volatile writer drops nothing to a reader it has matched
        self.declare_parameter("min_output_subscribers", 0)
        for k in ("lat_deg", "lon_deg", "alt_m"):
            self.declare_parameter(f"origin.{k}", float("nan"))
        nav_type = self.get_parameter("nav_type").value
        if nav_type not in ("odometry", "navstate"):
            raise ValueError(f"nav_type: expected 'odometry' or 'navstate', got {nav_type!r}")
        o = [self.get_parameter(f"origin.{k}").value for k in ("lat_deg", "lon_deg", "alt_m")]
        if not all(math.isfinite(x) for x in o):      # the fusion node's default map origin: its initial position
            init = sc.filter_initial_values()
            o = [init["lat_deg"], init["lon_deg"], init["alt_m"]]
        self.origin = (math.radians(o[0]), math.radians(o[1]), float(o[2]))
        self.law = GlideGuidance(cfg, parse_flight(dict(sc.data["flight"]))["vehicle"])
        qos = publisher_qos(sc["graph.qos_depth"])
        self.pub = self.create_publisher(GlideCommand, cfg.command_topic, qos)
        topic = self.get_parameter("nav_topic").value
        if nav_type == "odometry":
            self.sub = self.create_subscription(Odometry, topic, self._on_odom, qos)
        else:
            self.sub = self.create_subscription(NavState, topic, self._on_navstate, qos)
        # the time source waits until this subscription has matched its publishers from this side
        # (a reliable volatile reader drops what was sent before: the first states, and the loop would
        # wait command_timeout_s for their commands), and until the command publisher has matched its
        # subscribers (a collector matched late lost the first 18 s of commands in one CI pass); then
        # the allowance is unlimited
        inputs = InputsReady(self, lambda: [self.sub], required=[topic])
        n_out = int(self.get_parameter("min_output_subscribers").value)
        self.allowance = ClockAllowance(self, source=lambda: math.inf,
                                        ready=lambda: inputs() and all_matched([self.pub], n_out))
        self.counts = {"received": 0, "commands": 0, "off_grid": 0, "rejected not_finite": 0,
                       "rejected out_of_order": 0, "before_start": 0}
        self.last_t = -math.inf
        self.status = NodeStatus(self, "hyper_nav_guidance: guidance")
        self.create_timer(self.get_parameter("diagnostics_period_s").value, self._diag)

    def _on_odom(self, m: Odometry):
        p, q, v = m.pose.pose.position, m.pose.pose.orientation, m.twist.twist.linear
        pos, quat, vel = (p.x, p.y, p.z), (q.x, q.y, q.z, q.w), (v.x, v.y, v.z)
        if not finite(pos, quat, vel):
            self._reject(m, "not_finite")
            return
        self._act(stamp_to_s(m.header.stamp), *odometry_to_geodetic(pos, quat, vel, *self.origin))

    def _on_navstate(self, m: NavState):
        if not finite(m.lat_rad, m.lon_rad, m.alt_m, m.vel_enu_mps):
            self._reject(m, "not_finite")
            return
        self._act(stamp_to_s(m.header.stamp), m.lat_rad, m.lon_rad, m.alt_m, list(m.vel_enu_mps))

    def _reject(self, m, why):
        self.counts["received"] += 1
        self.counts[f"rejected {why}"] += 1

    def _act(self, t, lat, lon, alt, vel):
        self.counts["received"] += 1
        P = self.cfg.period_s
        if abs(t - round(t / P) * P) > 1e-6:
            self.counts["off_grid"] += 1
            return
        if t < self.cfg.t_start_s - 1e-9:
            self.counts["before_start"] += 1
            return
        if t <= self.last_t + 1e-9:
            self.counts["rejected out_of_order"] += 1
            return
        self.last_t = t
        c = self.law.command(t, lat, lon, alt, vel)
        msg = GlideCommand()
        msg.header.stamp.sec, msg.header.stamp.nanosec = s_to_stamp_fields(t)
        msg.header.frame_id = "enu"
        msg.bank_rad, msg.c_l = float(c.sigma_cmd_rad), float(c.c_l_cmd)
        msg.range_to_go_m, msg.terminal = float(c.range_to_go_m), bool(c.terminal)
        self.pub.publish(msg)
        self.counts["commands"] += 1

    def on_shutdown(self):
        self._diag()

    def _diag(self):
        values = dict(self.counts, last_stamp_s=f"{self.last_t:.3f}" if math.isfinite(self.last_t) else "none")
        self.status.publish("ok", "running", values)


def main(args=None):
    run_node(GuidanceNode, args)


if __name__ == "__main__":
    main()
