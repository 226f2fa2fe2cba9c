"""Land-vehicle constraint sources (``core.land_vehicle``), declared on the
IMU's own topic; none is in a default table (flight has neither)::

    filter:
      sources:
        imu:  {type: imu, topic: imu/data_raw}
        zupt: {type: zupt, topic: imu/data_raw, sigma_mps: 0.01}
        nhc:  {type: nhc, topic: imu/data_raw, sigma_mps: 0.1, rate_hz: 10}

* ``zupt``: zero-velocity update at each IMU epoch the standstill detector
  accepts (at most ``rate_hz``);
* ``nhc``: the non-holonomic constraint at ``rate_hz``, moving or not (a
  standing car has no lateral or vertical velocity either; and an IMU
  cannot tell a constant-velocity drive from a standstill, so no
  standstill test gates it).

Each IMU message reaches the ``imu`` source first (declared order), which
advances the filter to its epoch; the constraint is then queued at that
epoch.
"""
from __future__ import annotations

from ..conversions import imu_rates
from ..core.land_vehicle import NonHolonomic, StandstillDetector, ZeroVelocity
from ..core.params import FLOAT, positive
from .base import SourceType, register

_DETECTOR = (
    positive("window_s", FLOAT, 0.5, "standstill test window (s)"),
    positive("gyro_max_deg_per_s", FLOAT, 1.0, "standstill: every body rate below this over the window (deg/s)"),
    positive("accel_std_max_mps2", FLOAT, 0.1, "standstill: 1-sigma of |specific force| over the window below "
             "this (m/s^2)"),
)


class _OnImu(SourceType):
    MSG_TYPES = ("sensor_msgs/msg/Imu",)

    def __init__(self, spec, cfg=None):
        super().__init__(spec, cfg)
        self._next_t = -float("inf")

    def _due(self, t: float) -> bool:
        if t < self._next_t - 1e-9:
            return False
        self._next_t = t + 1.0 / self.p["rate_hz"]
        return True


@register
class ZuptSource(_OnImu):
    TYPE = "zupt"
    DESCRIPTION = "zero-velocity update at standstill (IMU standstill test; land vehicles)"
    PARAMS = _DETECTOR + (
        positive("sigma_mps", FLOAT, 0.01, "1-sigma of the zero velocity per axis (m/s)"),
        positive("rate_hz", FLOAT, 10.0, "at most this many updates per second"),
    )

    def __init__(self, spec, cfg=None):
        super().__init__(spec, cfg)
        self.detector = StandstillDetector(self.p["window_s"], self.p["gyro_max_deg_per_s"],
                                           self.p["accel_std_max_mps2"])

    def convert(self, role, msg, engine):
        t, w, f = imu_rates(msg)
        if not self.detector.add(t, w, f):
            self.counters["processed main: moving"] += 1
            return None
        if not self._due(t):
            return None
        self.counters["processed main: zupt"] += 1
        return self._queued(engine.add_measurement(ZeroVelocity(t, self.p["sigma_mps"] ** 2)))


@register
class NhcSource(_OnImu):
    TYPE = "nhc"
    DESCRIPTION = "non-holonomic constraint: zero lateral and vertical body velocity (land vehicles)"
    PARAMS = (
        positive("sigma_mps", FLOAT, 0.1, "1-sigma of the lateral and vertical body velocity (m/s)"),
        positive("rate_hz", FLOAT, 10.0, "updates per second"),
    )

    def convert(self, role, msg, engine):
        t, _, _ = imu_rates(msg)
        if not self._due(t):
            return None
        self.counters["processed main: nhc"] += 1
        return self._queued(engine.add_measurement(NonHolonomic(t, self.p["sigma_mps"] ** 2)))
