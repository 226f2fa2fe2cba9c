"""Static port node: ``static_port/pressure`` (sensor_msgs/FluidPressure) from
the scenario's ``static_port:`` block, on the simulated clock like the
simulator's own sensor nodes (``hyper_nav_sim.nodes.sensor_base``)."""
from __future__ import annotations

from sensor_msgs.msg import FluidPressure

from hyper_nav_filter.ros_util import run_node
from hyper_nav_sim.nodes.sensor_base import ClockDrivenSensor

from .model import TOPIC, messages


class StaticPortNode(ClockDrivenSensor):
    def __init__(self):
        super().__init__("static_port")
        sc = self.scenario
        self.msgs = messages(sc, sc.trajectory())
        self.pub = self.create_publisher(FluidPressure, TOPIC, self.qos)
        self.schedule([t for t, _, _ in self.msgs], self.pub, lambda i: self.msgs[i][2])

    def publishers_to_match(self):
        return [self.pub]


def main(args=None):
    run_node(StaticPortNode, args)


if __name__ == "__main__":
    main()
