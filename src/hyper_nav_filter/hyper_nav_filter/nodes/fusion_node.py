"""Fusion node: the ESKF engine on live IMU and GNSS messages.

Subscribes ``imu/data_raw`` (sensor_msgs/Imu) and, with ``filter.gnss_mode``
``loose`` (default), ``gnss/fix`` (NavSatFix) and ``gnss/vel``
(TwistWithCovarianceStamped, ENU); with ``tight``, ``gnss/raw``
(hyper_nav_msgs/GnssMeasurements) and ``gnss/ephemeris``
(hyper_nav_msgs/GnssEphemeris, reliable + transient local) instead, turned
into pseudorange updates (``core.gnss.raw_to_pseudoranges``; the filter
needs the ``clk`` state block; receiver corrections from the ``gnss.*``
parameters, see ``TIGHT_GNSS_PARAMETERS``). Publishes ``nav/state``
(hyper_nav_msgs/NavState), ``nav/odom`` (nav_msgs/Odometry), ``nav/fix``
(NavSatFix) and ``/diagnostics``. All math is in ``hyper_nav_filter.core``.
"""
from __future__ import annotations

from dataclasses import fields

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistWithCovarianceStamped
from hyper_nav_msgs.msg import GnssEphemeris, GnssMeasurements
from hyper_nav_msgs.msg import NavState as NavStateMsg
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import Imu, NavSatFix

from .. import conversions
from ..core.attitude import quat_xyzw_to_C
from ..core.config import FilterConfig
from ..core.fusion import FusionEngine
from ..core.gnss.raw_to_pseudoranges import TIGHT_GNSS_PARAMETERS, check_gnss_mode, tight_gnss_input
from ..core.nav_state import NavState
from ..output import OutputFrames, navsatfix_fields, navstate_fields, odometry_fields
from ..ros_util import all_matched, diagnostic_array, latched_qos, publisher_qos, run_node, subscriber_qos
from ..tight_input import TightGnssHandler


class FusionNode(Node):
    def __init__(self):
        super().__init__("fusion")
        cfg = {}
        for f in fields(FilterConfig):
            if f.init:
                default = list(f.default) if isinstance(f.default, tuple) else f.default
                cfg[f.name] = self.declare_parameter(f"filter.{f.name}", default).value
        self.cfg = FilterConfig.from_dict(cfg)
        self.gnss_mode = self.declare_parameter("filter.gnss_mode", "loose").value
        check_gnss_mode(self.gnss_mode, self.cfg)
        p = {name: self.declare_parameter(name, default).value for name, default in [
            ("init.t_s", 0.0), ("init.lat_deg", 0.0), ("init.lon_deg", 0.0), ("init.alt_m", 0.0),
            ("init.vel_enu_mps", [0.0, 0.0, 0.0]), ("init.q_b_enu_xyzw", [0.0, 0.0, 0.0, 1.0]),
            ("frames.map", "map"), ("frames.enu", "enu"), ("frames.body", "base_link"),
            ("origin.lat_deg", float("nan")), ("origin.lon_deg", float("nan")), ("origin.alt_m", float("nan")),
            ("qos.depth", 2000), ("qos.reliable_subscriptions", True), ("min_output_subscribers", 0),
            ("diagnostics_period_s", 1.0)]}
        self.p = p
        init = NavState(p["init.t_s"], np.deg2rad(p["init.lat_deg"]), np.deg2rad(p["init.lon_deg"]),
                        p["init.alt_m"], np.asarray(p["init.vel_enu_mps"], float),
                        quat_xyzw_to_C(p["init.q_b_enu_xyzw"]))
        self.engine = FusionEngine(self.cfg, init)
        self.tight = None
        if self.gnss_mode == "tight":
            tp = {name: self.declare_parameter(name, default).value
                  for name, default in TIGHT_GNSS_PARAMETERS.items()}
            self.tight = TightGnssHandler(self.engine, tight_gnss_input(tp))
        origin = [p["origin.lat_deg"], p["origin.lon_deg"], p["origin.alt_m"]]
        if not np.all(np.isfinite(origin)):
            origin = [p["init.lat_deg"], p["init.lon_deg"], p["init.alt_m"]]
        self.frames = OutputFrames(p["frames.map"], p["frames.enu"], p["frames.body"],
                                   np.deg2rad(origin[0]), np.deg2rad(origin[1]), origin[2])
        qos = publisher_qos(p["qos.depth"])
        self.pub_state = self.create_publisher(NavStateMsg, "nav/state", qos)
        self.pub_odom = self.create_publisher(Odometry, "nav/odom", qos)
        self.pub_fix = self.create_publisher(NavSatFix, "nav/fix", qos)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        self.counts = {f"published {t}": 0 for t in ("nav/state", "nav/odom", "nav/fix")}
        self._subs = []
        self._wait_timer = self.create_timer(0.05, self._start_when_ready)
        self.create_timer(p["diagnostics_period_s"], self._publish_diagnostics)

    def _start_when_ready(self):
        """Subscribe to inputs only once every output has its subscribers, so
        nothing computed is published into the void."""
        if not all_matched([self.pub_state, self.pub_odom, self.pub_fix], self.p["min_output_subscribers"]):
            return
        self._wait_timer.cancel()
        qos = subscriber_qos(self.p["qos.reliable_subscriptions"], self.p["qos.depth"])
        self._subs = [self.create_subscription(Imu, "imu/data_raw", self._on_imu, qos)]
        if self.tight is None:
            self._subs += [self.create_subscription(NavSatFix, "gnss/fix", self._on_fix, qos),
                           self.create_subscription(TwistWithCovarianceStamped, "gnss/vel", self._on_vel, qos)]
        else:
            # ephemerides first: when both are ready, the executor takes them in creation order
            self._subs += [self.create_subscription(GnssEphemeris, "gnss/ephemeris", self._on_ephemeris,
                                                    latched_qos(max(int(self.p["qos.depth"]), 500))),
                           self.create_subscription(GnssMeasurements, "gnss/raw", self._on_raw, qos)]
        self.get_logger().info("outputs matched; subscribed to " + ", ".join(s.topic_name for s in self._subs))

    def _on_imu(self, msg):
        self.engine.counters["imu_msgs"] += 1
        self.engine.add_imu_rates(*conversions.imu_rates(msg))
        if self.tight is not None:
            self.tight.feed()
        self._publish(self.engine.release())

    def _on_raw(self, msg):
        self._warn(self.tight.on_raw(msg))

    def _on_ephemeris(self, msg):
        self._warn(self.tight.on_ephemeris(msg))

    def _warn(self, reason):
        if reason is not None:
            self.get_logger().warning(f"rejected: {reason}", throttle_duration_sec=5.0)

    def _on_fix(self, msg):
        self.engine.counters["gnss_fix_msgs"] += 1
        self.engine.add_measurement(conversions.gnss_position(msg))

    def _on_vel(self, msg):
        self.engine.counters["gnss_vel_msgs"] += 1
        self.engine.add_measurement(conversions.gnss_velocity(msg))

    def _publish(self, solutions):
        for sol in solutions:
            m = NavStateMsg()
            _assign(m, navstate_fields(sol, self.cfg.layout, self.frames))
            self.pub_state.publish(m)
            o = Odometry()
            _assign(o, odometry_fields(sol, self.cfg.layout, self.frames))
            self.pub_odom.publish(o)
            f = NavSatFix()
            _assign(f, navsatfix_fields(sol, self.cfg.layout, self.frames))
            self.pub_fix.publish(f)
            for t in ("nav/state", "nav/odom", "nav/fix"):
                self.counts[f"published {t}"] += 1

    def on_shutdown(self):
        """Final /diagnostics on SIGINT/SIGTERM (ros_util.run_node): its
        published counts are the node's last word, matched by the recorder."""
        self._publish_diagnostics()

    def _publish_diagnostics(self):
        c = dict(self.engine.counters)
        c.update(self.counts)
        c["n_updates"] = self.engine.kf.n_updates
        c["n_rejected_gate"] = self.engine.kf.n_rejected
        c["last_nis"] = f"{self.engine.kf.last_nis:.3f}"
        c["gnss_mode"] = self.gnss_mode
        if self.tight is not None:
            c.update(self.tight.diagnostics())
        for kind, (acc, rej, nis_sum) in self.engine.kf.stats.items():
            c[f"{kind}_accepted"] = acc
            c[f"{kind}_gated"] = rej
            c[f"{kind}_mean_nis_per_dof"] = f"{nis_sum / max(acc, 1):.3f}"
        rejected = sum(v for k, v in c.items() if str(k).startswith("rejected_"))
        self.pub_diag.publish(diagnostic_array(self, "hyper_nav_filter: fusion", rejected == 0,
                                               f"{rejected} input messages rejected", c))


def _assign(msg, values: dict):
    """Set nested message fields from a flat {'a.b.c': value} dict."""
    for path, value in values.items():
        obj = msg
        parts = path.split(".")
        for part in parts[:-1]:
            obj = getattr(obj, part)
        setattr(obj, parts[-1], value)


def main(args=None):
    run_node(FusionNode, args)


if __name__ == "__main__":
    main()
