"""Tracker node: hypersonic target track from early-warning radar (seed 002).

Subscribes ``radar/track`` (sensor_msgs/NavSatFix: measured latitude,
longitude, altitude); publishes ``track/fix`` (NavSatFix, ENU position
covariance) and ``track/vel`` (TwistWithCovarianceStamped, local ENU) per
accepted measurement, stamped with the measurement epoch, and
``/diagnostics`` (counters, rejected input, the state's gamma/psi/chi and
the input u). The filter (``tracker.filter_type``: EKF, AEKF, LEKF, IMM) and
every number come from the ``tracker.*`` parameters (the scenario's
``tracker:`` block, written by ``run_graph``); all math is in
``hyper_nav_filter.core.target_tracking``.
"""
from __future__ import annotations

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistWithCovarianceStamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from sensor_msgs.msg import NavSatFix

from ..conversions import stamp_to_s
from hyper_nav_filter.core.target_tracking import params_store
from hyper_nav_filter.core.target_tracking.config import TrackerConfig, TrackerConfigError
from hyper_nav_filter.core.target_tracking.tracker import Tracker
from ..ros_util import all_matched, assign_fields, diagnostic_array, publisher_qos, run_node, subscriber_qos
from ..tracker_output import track_fix_fields, track_vel_fields

NODE_PARAMETERS = {   # name: (default, description)
    "init.t_s": (0.0, "epoch of the initial estimate (s, sim time)"),
    "init.state": ([0.0] * 7, "initial estimate [h_m, lon_rad, lat_rad, v_mps, gamma_rad, psi_rad, chi]"),
    "radar.rate_hz": (1.0, "nominal radar rate; longer gaps are bridged by predict-only steps"),
    "frames.enu": ("enu", "frame_id of track/vel (local-level ENU at the target)"),
    "frames.fix": ("wgs84", "frame_id of track/fix"),
    "qos.depth": (2000, "publisher/subscriber queue depth"),
    "qos.reliable_subscriptions": (True, "reliable (true) or sensor-data best-effort subscription"),
    "min_output_subscribers": (0, "subscribe to radar/track only when every output has this many subscribers"),
    "diagnostics_period_s": (1.0, "period of /diagnostics (s)"),
}


class TrackerNode(Node):
    def __init__(self):
        super().__init__("tracker")
        values = {}
        for name, default in TrackerConfig().as_parameters().items():
            values[name] = self.declare_parameter(
                name, default, ParameterDescriptor(description=f"seed 002 tracker: {name} (see TrackerConfig)")).value
        try:
            self.cfg = TrackerConfig.from_parameters(values)
        except TrackerConfigError as exc:
            raise SystemExit(f"tracker: bad parameter: {exc}") from None
        self.p = {name: self.declare_parameter(name, default, ParameterDescriptor(description=desc)).value
                  for name, (default, desc) in NODE_PARAMETERS.items()}
        x0 = np.asarray(self.p["init.state"], float)
        if x0.shape != (7,) or not np.all(np.isfinite(x0)):
            raise SystemExit(f"tracker: bad parameter: init.state: expected 7 finite numbers, got {self.p['init.state']}")
        if not self.p["radar.rate_hz"] > 0:
            raise SystemExit(f"tracker: bad parameter: radar.rate_hz: must be > 0, got {self.p['radar.rate_hz']}")
        lekf = None
        if self.cfg.filter_type == "LEKF":
            arch, variables, meta = params_store.load(self.cfg.lekf_parameters)
            lekf = (arch, variables)
            self.get_logger().info(f"L-EKF parameters '{self.cfg.lekf_parameters}' (data seed "
                                   f"{meta['data']['data_seed']}, {meta['n_parameters']} parameters)")
        self.tracker = Tracker(self.cfg, x0, self.p["init.t_s"], 1.0 / self.p["radar.rate_hz"], lekf)
        self.tracker.warm_up()
        qos = publisher_qos(self.p["qos.depth"])
        self.pub_fix = self.create_publisher(NavSatFix, "track/fix", qos)
        self.pub_vel = self.create_publisher(TwistWithCovarianceStamped, "track/vel", qos)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        self.counts = {"received radar/track": 0, "published track/fix": 0, "published track/vel": 0}
        self._sub = None
        self._wait_timer = self.create_timer(0.05, self._start_when_ready)
        self.create_timer(self.p["diagnostics_period_s"], self._publish_diagnostics)

    def _start_when_ready(self):
        if not all_matched([self.pub_fix, self.pub_vel], self.p["min_output_subscribers"]):
            return
        self._wait_timer.cancel()
        qos = subscriber_qos(self.p["qos.reliable_subscriptions"], self.p["qos.depth"])
        self._sub = self.create_subscription(NavSatFix, "radar/track", self._on_radar, qos)
        self.get_logger().info(f"{self.cfg.filter_type} tracker subscribed to radar/track")

    def _on_radar(self, msg: NavSatFix):
        self.counts["received radar/track"] += 1
        z = [msg.altitude, np.deg2rad(msg.longitude), np.deg2rad(msg.latitude)]
        reason = self.tracker.add_measurement(stamp_to_s(msg.header.stamp), z)
        if reason is not None:
            self.get_logger().warning(f"radar/track rejected: {reason}", throttle_duration_sec=5.0)
            return
        est = self.tracker.last
        fix = NavSatFix()
        assign_fields(fix, track_fix_fields(est, self.p["frames.fix"]))
        self.pub_fix.publish(fix)
        vel = TwistWithCovarianceStamped()
        assign_fields(vel, track_vel_fields(est, self.p["frames.enu"]))
        self.pub_vel.publish(vel)
        self.counts["published track/fix"] += 1
        self.counts["published track/vel"] += 1

    def on_shutdown(self):
        self._publish_diagnostics()

    def _publish_diagnostics(self):
        c = dict(self.tracker.counters)
        c.update(self.counts)
        est = self.tracker.last
        c.update({"filter_type": self.cfg.filter_type, "t_s": f"{est.t_s:.3f}",
                  "gamma_deg": f"{np.rad2deg(est.x[4]):.4f}", "psi_deg": f"{np.rad2deg(est.x[5]):.3f}",
                  "chi": f"{est.x[6]:.3f}", "lambda1": f"{est.u[0]:.4f}", "lambda2": f"{est.u[1]:.4f}",
                  "T_chi_s": f"{est.u[2]:.2f}"})
        rejected = sum(v for k, v in c.items() if str(k).startswith("rejected_"))
        self.pub_diag.publish(diagnostic_array(self, "hyper_nav_filter: tracker", rejected == 0,
                                               f"{rejected} radar messages rejected", c))


def main(args=None):
    run_node(TrackerNode, args)


if __name__ == "__main__":
    main()
