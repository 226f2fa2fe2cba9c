"""IMU source: sensor_msgs/Imu -> IMU samples that drive the filter's time.

Mapping (README, "IMU message"): over (previous stamp, header.stamp],
``angular_velocity`` = delta-theta / dt and ``linear_acceleration`` =
delta-v / dt (body FLU, float64), so increments are rate x stamp difference.
"""
from __future__ import annotations

from ..conversions import imu_rates
from .base import SourceType, register


@register
class ImuSource(SourceType):
    TYPE = "imu"
    MSG_TYPES = ("sensor_msgs/msg/Imu",)
    DESCRIPTION = "strapdown IMU increments as mean rates (drives the filter)"
    drives_time = True

    def convert(self, role, msg, engine):
        return self._queued(engine.add_imu_rates(*imu_rates(msg)))
