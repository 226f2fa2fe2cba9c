"""IMU source: sensor_msgs/Imu -> IMU samples that drive the filter's time.

Mapping (README, "IMU message"): over (previous stamp, header.stamp],
``angular_velocity`` = delta-theta / dt and ``linear_acceleration`` =
delta-v / dt (body FLU, float64), so increments are rate x stamp difference.

Structure load (seed 000, the elastic lever arm's known input u_q of eq. 22):
with ``load_topic`` set, a second sensor_msgs/Imu stream whose
``linear_acceleration`` is the load sensor's mean specific force over
(previous load stamp, header.stamp] (body FLU; the sim's IMU node publishes
it as ``imu/load`` when the scenario has the elastic lever arm). Each IMU
sample is held until a load sample stamped at or after its end has
arrived, then goes to the engine with the load samples stamped inside its
interval, (n, 3) (``ImuSample.load_f_b_mps2``): the arrival order of the two
topics does not change what the filter computes. A sample with no load inside
its interval goes without (the measured force stands in, counted), and so do
the oldest held samples when more than ``load_max_held`` wait (a load stream
that stopped).
"""
from __future__ import annotations

from collections import deque

import numpy as np

from ..conversions import imu_rates
from ..core.params import INT, STR, ParamSpec
from .base import SourceInput, SourceType, register

_EPS_S = 1e-6


@register
class ImuSource(SourceType):
    TYPE = "imu"
    MSG_TYPES = ("sensor_msgs/msg/Imu",)
    DESCRIPTION = "strapdown IMU increments as mean rates (drives the filter)"
    PARAMS = (ParamSpec("load_topic", STR, "",
                        "sensor_msgs/Imu topic of the structure's load (linear_acceleration: the load sensor's mean "
                        "specific force over its own interval, seed 000 eq. 22's u_q); empty: none"),
              ParamSpec("load_max_held", INT, 50, "IMU samples held waiting for their load before the oldest "
                        "goes without", lo=1))
    drives_time = True

    def __init__(self, spec, cfg=None):
        super().__init__(spec, cfg)
        self._held: deque = deque()      # (t_s, omega_b_radps, f_b_mps2) waiting for their load
        self._loads: deque = deque()     # (t_s, f_b_mps2) of the load stream, not yet used

    def inputs(self) -> list[SourceInput]:
        out = super().inputs()
        if self.p.get("load_topic"):
            out.append(SourceInput("load", self.p["load_topic"], "sensor_msgs/msg/Imu"))
        return out

    def convert(self, role, msg, engine):
        if not self.p.get("load_topic"):
            return self._queued(engine.add_imu_rates(*imu_rates(msg)))
        t, w, f = imu_rates(msg)
        if role == "load":
            if self._loads and t <= self._loads[-1][0]:
                return "load_out_of_order"
            self._loads.append((t, f))
            return self._release(engine)
        self._held.append((t, w, f))
        return self._release(engine)

    def _release(self, engine) -> str | None:
        """Send the held IMU samples whose load has arrived (or that waited
        too long) to the engine, in order; the first rejection's reason."""
        reason = None
        t_load = self._loads[-1][0] if self._loads else -np.inf
        while self._held and (t_load >= self._held[0][0] - _EPS_S or len(self._held) > self.p["load_max_held"]):
            t, w, f = self._held.popleft()
            t_prev = engine.t_latest_s
            while self._loads and self._loads[0][0] <= t_prev + _EPS_S:
                self._loads.popleft()                       # before this interval (or a rejected sample's)
            inside = []
            while self._loads and self._loads[0][0] <= t + _EPS_S:
                inside.append(self._loads.popleft()[1])
            if not inside:
                self.counters["processed main: without load"] += 1
            r = self._queued(engine.add_imu_rates(t, w, f, np.array(inside) if inside else None))
            reason = reason or r
        return reason

    def diagnostics(self) -> dict:
        out = super().diagnostics()
        if self.p.get("load_topic"):
            out["held imu waiting for load"] = len(self._held)
        return out
