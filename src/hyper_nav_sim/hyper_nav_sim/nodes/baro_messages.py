"""The barometer's messages (``baro/pressure``, sensor_msgs/FluidPressure),
made once for the node (``baro_node``) and for Monte Carlo (the barometer's
``SensorNode.mc_feed``): the same pressures, variances and stamps. No rclpy."""
from __future__ import annotations

import numpy as np

from hyper_nav_filter.conversions import s_to_stamp_fields

from ..core import simulate
from ..core.baro_model import BaroErrors

TOPIC = "baro/pressure"


def pressure_samples(sc, traj):
    """(t_s, pressure Pa, variance Pa^2) of the scenario's ``barometer:``
    block; no sample above the altimeter's ceiling (non-finite pressure)."""
    t_s, p_pa, _ = simulate.baro_stream(sc, traj)
    ok = np.isfinite(p_pa)
    err = BaroErrors.from_config(sc.data["barometer"], prefix="barometer")
    return t_s[ok], p_pa[ok], [float(v) for v in err.pressure_variance_pa2(p_pa[ok])]


def fill_pressure(msg, t_s: float, p_pa: float, var_pa2: float, frame_id: str):
    """A FluidPressure message (or any object of its shape) at epoch t_s."""
    msg.header.stamp.sec, msg.header.stamp.nanosec = s_to_stamp_fields(float(t_s))
    msg.header.frame_id = frame_id
    msg.fluid_pressure = float(p_pa)
    msg.variance = float(var_pa2)
    return msg


def feed(sc, traj, frame_id: str = "base_link") -> list:
    """[(t_s, topic, FluidPressure)]: what the node publishes, for Monte Carlo."""
    from sensor_msgs.msg import FluidPressure
    t_s, p_pa, var = pressure_samples(sc, traj)
    return [(float(t), TOPIC, fill_pressure(FluidPressure(), t, p, v, frame_id)) for t, p, v in zip(t_s, p_pa, var)]
