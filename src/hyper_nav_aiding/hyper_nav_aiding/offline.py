"""The virtual GNSS node's logic over recorded messages (no ROS): (topic,
message) pairs in the order the node would have received them (a bag's log
order), through the node's own input handler, to the virtual epochs the
live node publishes (a graph test compares them)."""
from __future__ import annotations

from .parameters import VirtualGnssNodeParams
from .virtual_input import VirtualGnssInput


def run_virtual_offline(records, params: VirtualGnssNodeParams) -> tuple[list, VirtualGnssInput]:
    """[(RawGnssEpoch, elevation, azimuth)] in publication order, and the input handler."""
    inp = VirtualGnssInput(params)
    fused = params.config.position_source == "fused"
    out = []
    for topic, msg in records:
        topic = topic.lstrip("/")
        if topic == "gnss/ephemeris":
            inp.on_ephemeris(msg)
        elif topic == "gnss/raw":
            out += inp.on_raw(msg)[0]
        elif topic == "imu/data_raw":
            out += inp.on_imu(msg)
        elif topic == "nav/state" and fused:
            out += inp.on_state(msg)
        elif topic == "gnss/fix" and not fused:
            inp.on_fix(msg)
    return out, inp
