"""Barometer node: ``baro/pressure`` (sensor_msgs/FluidPressure, Pa) with the
static pressure of the US Standard Atmosphere 1976 at the true altitude plus
the scenario's ``barometer:`` noise model (valid to 60 km; above the model's
ceiling the altimeter reports no data). Runs only when the scenario has a
``barometer:`` block."""
from __future__ import annotations

import numpy as np
from sensor_msgs.msg import FluidPressure

from hyper_nav_filter.ros_util import declare_params, run_node

from ..core import simulate
from ..core.baro_model import BaroErrors
from .params import frame_id
from .sensor_base import ClockDrivenSensor


class BaroNode(ClockDrivenSensor):
    def __init__(self):
        super().__init__("barometer")
        self.frame_id = declare_params(self, (frame_id("base_link", "pressure"),))["frame_id"]
        sc = self.scenario
        t_s, p_pa, _ = simulate.baro_stream(sc, sc.trajectory())
        ok = np.isfinite(p_pa)                 # no data above the altimeter's ceiling
        self.t_s, self.p_pa = t_s[ok], p_pa[ok]
        err = BaroErrors.from_config(sc.data["barometer"], prefix="barometer")
        self.var = [float((err.pressure_noise_rel * p) ** 2 + err.pressure_noise_pa ** 2) for p in self.p_pa]
        self.pub = self.create_publisher(FluidPressure, "baro/pressure", self.qos)
        self.schedule(self.t_s, self.pub, self._make)

    def publishers_to_match(self):
        return [self.pub]

    def _make(self, i: int) -> FluidPressure:
        m = self.stamp(FluidPressure(), self.t_s[i], self.frame_id)
        m.fluid_pressure = float(self.p_pa[i])
        m.variance = self.var[i]
        return m


def main(args=None):
    run_node(BaroNode, args)


if __name__ == "__main__":
    main()
