"""The geomagnetic matching node (seed 003), declared to the launcher and the scenario loader (``hyper_nav_filter.aiding_nodes``; the
``hyper_nav.aiding_nodes`` entry point ``geomag`` in ``setup.py``): its executable, the scenario block it reads with
the block's validator, its inputs and outputs, and its ROS parameters from a scenario. The configuration modules are
imported when a block is validated or a node is started, not when the descriptor is read (every process that loads
a scenario reads it). No rclpy here.
"""
from __future__ import annotations

from hyper_nav_filter.aiding_nodes import AidingNode

from .parameters import geomag_parameters

PACKAGE = "hyper_nav_aiding"


# ---- geomagnetic matching (seed 003) -----------------------------------------------------
def _geomag_config(block: dict):
    from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig
    return GeomagConfig.from_dict(block)


def _geomag_map_epoch(data: dict):
    from hyper_nav_aiding.geomag.core.map_epoch import check_scenario
    return check_scenario(data)


def _geomag_mc_feed(sc, traj, cfg, publish):
    from .mc_feed import mc_feed
    return mc_feed(sc, traj, cfg, publish)


GEOMAG = AidingNode(
    name="geomag", package=PACKAGE, executable="geomag_node", block="geomag",
    validate=_geomag_config, parameters=geomag_parameters,
    inputs=lambda block: {"imu/mag"}, outputs=lambda block: ["geomag/fix"], output_wait_parameter="min_subscribers",
    validate_scenario=_geomag_map_epoch, gates_clock=True, mc_feed=_geomag_mc_feed)
