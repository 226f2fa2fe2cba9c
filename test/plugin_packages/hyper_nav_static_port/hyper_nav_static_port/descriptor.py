"""The static port declared to the launcher, the scenario loader and Monte
Carlo (``hyper_nav_sim.sensors``): its executable, the ``static_port``
block (its fields and validator; the block starts the node), its topic with
the rate from the block, and its Monte Carlo feed (the node's own
messages). No rclpy here."""
from __future__ import annotations

from dataclasses import fields

from hyper_nav_sim.sensors import SensorNode

from .model import TOPIC, StaticPortConfig, messages

STATIC_PORT = SensorNode(
    name="static_port", package="hyper_nav_static_port", executable="static_port_node", block="static_port",
    optional=True, order=60,
    topics=lambda sc: {TOPIC: StaticPortConfig.from_block(sc.data.get("static_port")).rate_hz},
    fields=lambda: [f.name for f in fields(StaticPortConfig)], validate=StaticPortConfig.from_block,
    replay_topics=(TOPIC,), mc_feed=messages)
