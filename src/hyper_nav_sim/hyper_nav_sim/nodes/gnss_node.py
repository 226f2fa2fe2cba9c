"""GNSS node: ``gnss/fix`` (sensor_msgs/NavSatFix) and ``gnss/vel``
(geometry_msgs/TwistWithCovarianceStamped, frame ``enu``: linear = ENU
velocity of the antenna w.r.t. Earth) at the scenario GNSS rate.

Messages are released ``gnss.latency_s`` after their epoch (receiver
latency); header.stamp stays the measurement epoch.
"""
from __future__ import annotations

import numpy as np
from geometry_msgs.msg import TwistWithCovarianceStamped
from sensor_msgs.msg import NavSatFix, NavSatStatus

from hyper_nav_filter.ros_util import run_node

from ..core import simulate
from .sensor_base import ClockDrivenSensor


class GnssNode(ClockDrivenSensor):
    def __init__(self):
        super().__init__("gnss")
        self.frame_id = self.declare_parameter("frame_id", "gnss_antenna").value
        self.enu_frame = self.declare_parameter("enu_frame_id", "enu").value
        sc = self.scenario
        self.latency_s = float(self.declare_parameter("latency_s", sc["gnss.latency_s"]).value)
        self.fixes = simulate.gnss_stream(sc, sc.trajectory())
        self.pos_cov = np.diag(self.fixes.pos_sigma_enu_m**2).ravel().tolist()
        vcov = np.zeros((6, 6))
        vcov[:3, :3] = np.diag(self.fixes.vel_sigma_enu_mps**2)
        vcov[3:, 3:] = np.eye(3) * 1e6          # angular part unknown: huge variance
        self.vel_cov = vcov.ravel().tolist()
        self.pub_fix = self.create_publisher(NavSatFix, "gnss/fix", self.qos)
        self.pub_vel = self.create_publisher(TwistWithCovarianceStamped, "gnss/vel", self.qos)
        self.schedule(self.fixes.t_s, self.pub_fix, self._make_fix)
        self.schedule(self.fixes.t_s, self.pub_vel, self._make_vel)

    def publishers_to_match(self):
        return [self.pub_fix, self.pub_vel]

    def _make_fix(self, i: int) -> NavSatFix:
        f = self.fixes
        m = self.stamp(NavSatFix(), f.t_s[i], self.frame_id)
        m.status.status = NavSatStatus.STATUS_FIX
        m.status.service = NavSatStatus.SERVICE_GPS
        m.latitude, m.longitude = float(np.rad2deg(f.lat_rad[i])), float(np.rad2deg(f.lon_rad[i]))
        m.altitude = float(f.alt_m[i])
        m.position_covariance = self.pos_cov
        m.position_covariance_type = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
        return m

    def _make_vel(self, i: int) -> TwistWithCovarianceStamped:
        f = self.fixes
        m = self.stamp(TwistWithCovarianceStamped(), f.t_s[i], self.enu_frame)
        v = m.twist.twist.linear
        v.x, v.y, v.z = map(float, f.vel_enu_mps[i])
        m.twist.covariance = self.vel_cov
        return m


def main(args=None):
    run_node(GnssNode, args)


if __name__ == "__main__":
    main()
