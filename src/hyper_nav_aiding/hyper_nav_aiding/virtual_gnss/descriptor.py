"""The virtual GNSS node (seed 004 section 2.3), declared to the launcher and the scenario loader (``hyper_nav_filter.aiding_nodes``; the
``hyper_nav.aiding_nodes`` entry point ``virtual_gnss`` in ``setup.py``): its executable, the scenario block it reads with
the block's validator, its inputs and outputs, and its ROS parameters from a scenario. The configuration modules are
imported when a block is validated or a node is started, not when the descriptor is read (every process that loads
a scenario reads it). No rclpy here.
"""
from __future__ import annotations

from hyper_nav_filter.aiding_nodes import AidingNode, output_deadline_s

PACKAGE = "hyper_nav_aiding"


# ---- virtual GNSS (seed 004 section 2.3) ------------------------------------------------
def _virtual_gnss_config(block: dict):
    from hyper_nav_aiding.virtual_gnss.core.virtual_gnss_config import VirtualGnssConfig
    return VirtualGnssConfig.from_config(block)


def _virtual_gnss_parameters(sc) -> dict:
    from hyper_nav_aiding.virtual_gnss.parameters import from_scenario
    return {**from_scenario(sc), "clock.deadline_s": output_deadline_s(sc)}


def _virtual_gnss_inputs(block: dict) -> set[str]:
    alpha_beta = (block or {}).get("position_source") == "alpha_beta"
    return {"gnss/raw", "gnss/ephemeris", "imu/data_raw"} | ({"gnss/fix"} if alpha_beta else set())


VIRTUAL_GNSS = AidingNode(
    name="virtual_gnss", package=PACKAGE, executable="virtual_gnss_node", block="virtual_gnss",
    validate=_virtual_gnss_config, parameters=_virtual_gnss_parameters, inputs=_virtual_gnss_inputs,
    outputs=lambda block: [_virtual_gnss_config(block).topic], output_wait_parameter="min_output_subscribers",
    gates_clock=True)
