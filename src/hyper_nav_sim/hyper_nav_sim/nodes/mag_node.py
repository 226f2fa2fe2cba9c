"""Magnetometer node: ``imu/mag`` (sensor_msgs/MagneticField, tesla, body
FLU) with the WMM field (pygeomag) at the true position and epoch; on a
commanded flight (issue 36) along the steered flight, epoch by epoch
(``core.flown_streams.FlownMag``)."""
from __future__ import annotations

import numpy as np
from sensor_msgs.msg import MagneticField

from hyper_nav_filter.ros_util import declare_params, run_node

from ..core import simulate
from ..core.commanded_flight import is_commanded
from ..core.flown_streams import FlownMag
from .params import frame_id
from .sensor_base import ClockDrivenSensor


class MagNode(ClockDrivenSensor):
    def __init__(self):
        super().__init__("magnetometer")
        self.frame_id = declare_params(self, (frame_id("magnetometer", "magnetometer"),))["frame_id"]
        sc = self.scenario
        var = (sc["magnetometer.noise_nT"] * 1e-9) ** 2
        self.cov = np.diag([var] * 3).ravel().tolist()
        self.pub = self.create_publisher(MagneticField, "imu/mag", self.qos)
        if is_commanded(sc):                 # issue 36: the field along the steered flight, epoch by epoch
            self.flown = FlownMag(sc, self.follow_flight(self._on_flown).flight)
            return
        self.t_s, self.field_T = simulate.mag_stream(sc, sc.trajectory())
        self.schedule(self.t_s, self.pub, self._make)

    def stream_complete(self) -> bool:
        return self.mirror is None or self.flown.done

    def _on_flown(self):
        t, b = self.flown.until_flown()
        if len(t):
            self.schedule(t, self.pub, lambda i, t=t, b=b: self._msg(t[i], b[i]))

    def publishers_to_match(self):
        return [self.pub]

    def _make(self, i: int) -> MagneticField:
        return self._msg(self.t_s[i], self.field_T[i])

    def _msg(self, t_s: float, field_T) -> MagneticField:
        m = self.stamp(MagneticField(), t_s, self.frame_id)
        m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z = map(float, field_T)
        m.magnetic_field_covariance = self.cov
        return m


def main(args=None):
    run_node(MagNode, args)


if __name__ == "__main__":
    main()
