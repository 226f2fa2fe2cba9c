"""IMU source: sensor_msgs/Imu -> IMU samples that drive the filter's time.

Mapping (README, "IMU message"): over (previous stamp, header.stamp],
``angular_velocity`` = delta-theta / dt and ``linear_acceleration`` =
delta-v / dt (body FLU, float64), so increments are rate x stamp difference.

Structure load (seed 000, the elastic lever arm's known input u_q of eq. 22):
with ``load_topic`` set, a second sensor_msgs/Imu stream whose
``linear_acceleration`` is the load sensor's mean specific force over
(previous load stamp, header.stamp] (body FLU; the sim's IMU node publishes
it as ``imu/load`` when the scenario has the elastic lever arm). Each IMU
sample is held until a load sample stamped at or after its end has arrived,
then goes to the engine with the load samples stamped inside its interval,
(n, 3) (``ImuSample.load_f_b_mps2``; ``core.imu_load.ImuLoadPairing``): the
arrival order of the two topics does not change what the filter computes.
A sample with no load inside its interval goes without (the measured force
stands in; counted), and so do the oldest held samples when more than
``load_max_held`` wait (a load stream that stopped).
"""
from __future__ import annotations

from ..conversions import imu_rates
from ..core.imu_load import ImuLoadPairing
from ..core.params import INT, STR, ParamSpec
from .base import SourceInput, SourceType, register


@register
class ImuSource(SourceType):
    TYPE = "imu"
    MSG_TYPES = ("sensor_msgs/msg/Imu",)
    DESCRIPTION = "strapdown IMU increments as mean rates (drives the filter)"
    PARAMS = (ParamSpec("load_topic", STR, "",
                        "sensor_msgs/Imu topic of the structure's load (linear_acceleration: the load sensor's mean "
                        "specific force over its own interval, seed 000 eq. 22's u_q); empty: none"),
              # the load stream (8 messages per IMU sample) comes in behind the IMU under load: 50 held samples
              # were too few in a graph test at real-time factor 2 (535 of 1500 went without their load)
              ParamSpec("load_max_held", INT, 1000, "IMU samples held waiting for their load before the oldest "
                        "goes without", lo=1))
    drives_time = True

    def __init__(self, spec, cfg=None):
        super().__init__(spec, cfg)
        self.pairing = ImuLoadPairing(self.p.get("load_max_held", 1000))

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
            if not self.pairing.add_load(t, f):
                return "load_out_of_order"
        else:
            self.pairing.add_imu(t, w, f)
        reason = None
        for t, w, f, load in self.pairing.ready(lambda: engine.t_latest_s):
            if load is None:
                self.counters["processed main: without load"] += 1
            reason = reason or self._queued(engine.add_imu_rates(t, w, f, load))
        return reason

    @property
    def n_held_imu(self) -> int:
        return self.pairing.n_held

    def diagnostics(self) -> dict:
        out = super().diagnostics()
        if self.p.get("load_topic"):
            out["held imu waiting for load"] = self.pairing.n_held
        return out
