"""Barometer node: ``baro/pressure`` (sensor_msgs/FluidPressure, Pa) with the
static pressure of the US Standard Atmosphere 1976 at the true altitude plus
the scenario's ``barometer:`` noise model (valid to 60 km; above the model's
ceiling the altimeter reports no data). Runs only when the scenario has a
``barometer:`` block."""
from __future__ import annotations

from sensor_msgs.msg import FluidPressure

from hyper_nav_filter.ros_util import declare_params, run_node

from .baro_messages import TOPIC, fill_pressure, pressure_samples
from .params import frame_id
from ..core.flown_streams import refuse_commanded
from .sensor_base import ClockDrivenSensor


class BaroNode(ClockDrivenSensor):
    def __init__(self):
        super().__init__("barometer")
        self.frame_id = declare_params(self, (frame_id("base_link", "pressure"),))["frame_id"]
        sc = self.scenario
        refuse_commanded(sc, "the barometer node")      # issue 36: its model takes the whole trajectory
        # no data above the altimeter's ceiling; the variance as Monte Carlo draws it (baro_messages)
        self.t_s, self.p_pa, self.var = pressure_samples(sc, sc.trajectory())
        self.pub = self.create_publisher(FluidPressure, TOPIC, self.qos)
        self.schedule(self.t_s, self.pub, self._make)

    def publishers_to_match(self):
        return [self.pub]

    def _make(self, i: int) -> FluidPressure:
        return fill_pressure(FluidPressure(), self.t_s[i], self.p_pa[i], self.var[i], self.frame_id)


def main(args=None):
    run_node(BaroNode, args)


if __name__ == "__main__":
    main()
