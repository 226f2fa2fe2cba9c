"""IMU node: ``imu/data_raw`` (sensor_msgs/Imu) at the scenario IMU rate.

Mapping of increments onto the message (README, "IMU message"): over the
interval (previous stamp, header.stamp], angular_velocity = delta-theta / dt
and linear_acceleration = delta-v / dt in body FLU (frame ``base_link``).
No orientation: orientation_covariance[0] = -1. The rate covariances are the
white-noise variances at the sample rate (ARW^2 / dt, VRW^2 / dt).

With the scenario's elastic lever arm on (seed 000), ``imu/load`` carries the
structure's load sensor (``simulate._measured_load``, at
``lever_arm.load_sensor_rate_hz``): one sensor_msgs/Imu per load sample,
linear_acceleration = its mean specific force over (previous load stamp,
header.stamp] (body FLU), angular_velocity zero with covariance[0] = -1
(not measured). The load samples of an IMU interval are queued before the
IMU sample that ends it. Other scenarios publish no load topic.

On a commanded flight (issue 36) the samples are those of the steered
flight, drawn step by step as the node's mirror of it is flown
(``core.flown_streams.FlownImu``; ``sensor_base.follow_flight``); the
elastic lever arm is refused there (ValueError at start).
"""
from __future__ import annotations

import numpy as np
from sensor_msgs.msg import Imu

from hyper_nav_filter.ros_util import declare_params, run_node

from ..core import simulate
from ..core.commanded_flight import is_commanded
from ..core.flown_streams import FlownImu
from ..core.imu_model import ImuErrors
from .params import frame_id
from .sensor_base import ClockDrivenSensor


class ImuNode(ClockDrivenSensor):
    def __init__(self):
        super().__init__("imu")
        self.frame_id = declare_params(self, (frame_id("imu_link", "IMU"),))["frame_id"]
        sc = self.scenario
        err = ImuErrors.from_scenario(sc)
        dt = 1.0 / sc["imu.rate_hz"]
        self.gyro_var = err.gyro_arw_rad_per_sqrt_s**2 / dt
        self.accel_var = err.accel_vrw_mps_per_sqrt_s**2 / dt
        self.pub = self.create_publisher(Imu, "imu/data_raw", self.qos)
        self.pub_load = None
        if is_commanded(sc):                 # issue 36: the samples of the steered flight, step by step
            self.flown = FlownImu(sc, self.follow_flight(self._on_flown).flight)
            return
        self.stream = simulate.imu_stream(sc, sc.trajectory())
        if self.stream.load_f_b_mps2 is not None:
            load = self.stream.load_f_b_mps2.reshape(len(self.stream.t_s), -1, 3)
            n_sub = load.shape[1]
            t_sub = self.stream.t_s[:, None] - dt + (dt / n_sub) * np.arange(1, n_sub + 1)
            t_sub[:, -1] = self.stream.t_s           # the last load sample ends with the IMU interval
            self._load_t, self._load = t_sub.ravel(), load.reshape(-1, 3)
            self.pub_load = self.create_publisher(Imu, "imu/load", self.qos)
            self.schedule(self._load_t, self.pub_load, self._make_load)    # before the IMU sample at equal epochs
        self.schedule(self.stream.t_s, self.pub, self._make)

    def stream_complete(self) -> bool:
        return self.mirror is None or self.flown.done

    def _on_flown(self):
        t, dth, dv = self.flown.until_flown()
        if len(t):
            dt = self.flown.dt_s
            self.schedule(t, self.pub, lambda i, t=t, w=dth / dt, a=dv / dt: self._imu_msg(t[i], w[i], a[i]))

    def publishers_to_match(self):
        return [self.pub] if self.pub_load is None else [self.pub, self.pub_load]

    def _make_load(self, i: int) -> Imu:
        m = self.stamp(Imu(), self._load_t[i], self.frame_id)
        m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z = map(float, self._load[i])
        m.orientation_covariance[0] = -1.0
        m.angular_velocity_covariance[0] = -1.0
        return m

    def _make(self, i: int) -> Imu:
        s, dt = self.stream, self.stream.dt_s
        return self._imu_msg(s.t_s[i], s.dtheta_b_rad[i] / dt, s.dvel_b_mps[i] / dt)

    def _imu_msg(self, t_s: float, w, a) -> Imu:
        m = self.stamp(Imu(), t_s, self.frame_id)
        m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = map(float, w)
        m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z = map(float, a)
        m.orientation_covariance[0] = -1.0
        m.angular_velocity_covariance = np.diag([self.gyro_var] * 3).ravel().tolist()
        m.linear_acceleration_covariance = np.diag([self.accel_var] * 3).ravel().tolist()
        return m


def main(args=None):
    run_node(ImuNode, args)


if __name__ == "__main__":
    main()
