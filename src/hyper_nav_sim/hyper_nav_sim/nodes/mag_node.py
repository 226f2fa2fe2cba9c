"""Magnetometer node: ``imu/mag`` (sensor_msgs/MagneticField, tesla, body
FLU) with the WMM field (pygeomag) at the true position and epoch."""
from __future__ import annotations

import numpy as np
from sensor_msgs.msg import MagneticField

from hyper_nav_filter.ros_util import declare_params, run_node

from ..core import simulate
from .params import frame_id
from .sensor_base import ClockDrivenSensor


class MagNode(ClockDrivenSensor):
    def __init__(self):
        super().__init__("magnetometer")
        self.frame_id = declare_params(self, (frame_id("magnetometer", "magnetometer"),))["frame_id"]
        sc = self.scenario
        self.t_s, self.field_T = simulate.mag_stream(sc, sc.trajectory())
        var = (sc["magnetometer.noise_nT"] * 1e-9) ** 2
        self.cov = np.diag([var] * 3).ravel().tolist()
        self.pub = self.create_publisher(MagneticField, "imu/mag", self.qos)
        self.schedule(self.t_s, self.pub, self._make)

    def publishers_to_match(self):
        return [self.pub]

    def _make(self, i: int) -> MagneticField:
        m = self.stamp(MagneticField(), self.t_s[i], self.frame_id)
        m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z = map(float, self.field_T[i])
        m.magnetic_field_covariance = self.cov
        return m


def main(args=None):
    run_node(MagNode, args)


if __name__ == "__main__":
    main()
