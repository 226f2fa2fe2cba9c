"""Early-warning radar node: ``radar/track`` (sensor_msgs/NavSatFix: the
vehicle's measured latitude, longitude and altitude, seed 002 section 3.2)
with the radar's noise (2000 m, 0.01 rad, 0.01 rad) as an ENU covariance at
the measured point. Runs only when the scenario has a ``radar:`` block."""
from __future__ import annotations

import numpy as np
from sensor_msgs.msg import NavSatFix, NavSatStatus

from hyper_nav_gnss import earth
from hyper_nav_filter.ros_util import declare_params, run_node

from ..core import simulate
from .params import frame_id
from ..core.flown_streams import refuse_commanded
from .sensor_base import ClockDrivenSensor


class RadarNode(ClockDrivenSensor):
    def __init__(self):
        super().__init__("radar")
        self.frame_id = declare_params(self, (frame_id("radar", "radar track"),))["frame_id"]
        sc = self.scenario
        refuse_commanded(sc, "the radar node")      # issue 36: its model takes the whole trajectory
        self.meas = simulate.radar_stream(sc, sc.trajectory())
        cfg = sc.data["radar"]
        self.sig = (float(cfg.get("sigma_alt_m", 2000.0)), float(cfg.get("sigma_lon_rad", 0.01)),
                    float(cfg.get("sigma_lat_rad", 0.01)))
        self.pub = self.create_publisher(NavSatFix, "radar/track", self.qos)
        self.schedule(self.meas.t_s, self.pub, self._make)

    def publishers_to_match(self):
        return [self.pub]

    def _make(self, i: int) -> NavSatFix:
        r = self.meas
        m = self.stamp(NavSatFix(), r.t_s[i], self.frame_id)
        m.status.status = NavSatStatus.STATUS_FIX
        m.latitude, m.longitude = float(np.rad2deg(r.lat_rad[i])), float(np.rad2deg(r.lon_rad[i]))
        m.altitude = float(r.alt_m[i])
        r_m, r_n = earth.radii(r.lat_rad[i])
        s_alt, s_lon, s_lat = self.sig
        var_e = (s_lon * (r_n + r.alt_m[i]) * np.cos(r.lat_rad[i])) ** 2
        var_n = (s_lat * (r_m + r.alt_m[i])) ** 2
        m.position_covariance = [var_e, 0.0, 0.0, 0.0, var_n, 0.0, 0.0, 0.0, s_alt**2]
        m.position_covariance_type = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
        return m


def main(args=None):
    run_node(RadarNode, args)


if __name__ == "__main__":
    main()
