"""This package's aiding nodes, declared to the launcher and the scenario
loader (``hyper_nav_sim.core.aiding_nodes``; the ``hyper_nav.aiding_nodes``
entry points in ``setup.py``). Each names its executable, the scenario block
it reads with the block's validator, its inputs and outputs, and writes its
ROS parameters from a scenario with the same helpers (``flat_parameters``,
``filter_parameters``). The configuration modules are imported when a block
is validated or a node is started, not when the descriptors are read (every
process that loads a scenario reads them). No rclpy here.
"""
from __future__ import annotations

from hyper_nav_sim.core.aiding_nodes import AidingNode, filter_parameters, flat_parameters

PACKAGE = "hyper_nav_aiding"


# ---- virtual GNSS (seed 004 section 2.3) ------------------------------------------------
def _virtual_gnss_config(block: dict):
    from .core.virtual_gnss_config import VirtualGnssConfig
    return VirtualGnssConfig.from_config(block)


def _virtual_gnss_parameters(sc) -> dict:
    from .parameters import from_scenario
    return from_scenario(sc)


def _virtual_gnss_inputs(block: dict) -> set[str]:
    alpha_beta = (block or {}).get("position_source") == "alpha_beta"
    return {"gnss/raw", "gnss/ephemeris", "imu/data_raw"} | ({"gnss/fix"} if alpha_beta else set())


VIRTUAL_GNSS = AidingNode(
    name="virtual_gnss", package=PACKAGE, executable="virtual_gnss_node", block="virtual_gnss",
    validate=_virtual_gnss_config, parameters=_virtual_gnss_parameters, inputs=_virtual_gnss_inputs,
    outputs=lambda block: [_virtual_gnss_config(block).topic], output_wait_parameter="min_output_subscribers")


# ---- geomagnetic matching (seed 003) -----------------------------------------------------
def _geomag_config(block: dict):
    from .core.geomag_config import GeomagConfig
    return GeomagConfig.from_dict(block)


def _geomag_parameters(sc) -> dict:
    # the block's ``reproduction`` part configures the offline reproduction only
    return {**flat_parameters(sc.data.get("geomag") or {}, "geomag", skip=("reproduction",)),
            "qos.depth": int(sc["graph.qos_depth"])}


GEOMAG = AidingNode(
    name="geomag", package=PACKAGE, executable="geomag_node", block="geomag",
    validate=_geomag_config, parameters=_geomag_parameters,
    inputs=lambda block: {"imu/mag"}, outputs=lambda block: ["geomag/fix"], output_wait_parameter="min_subscribers")


# ---- lever-arm learning, RL-DLAC (seed 000) ----------------------------------------------
def _lever_arm_config(block: dict):
    from .core.lever_arm.config import LeverArmLearningConfig
    return LeverArmLearningConfig.from_block(block)


def _lever_arm_parameters(sc) -> dict:
    # it replays windows through the filter: the filter configuration, and its own block
    return {**filter_parameters(sc), **flat_parameters(sc.data.get("lever_arm_learning") or {})}


LEVER_ARM = AidingNode(
    name="lever_arm", package=PACKAGE, executable="lever_arm_node", block="lever_arm_learning",
    validate=_lever_arm_config, parameters=_lever_arm_parameters,
    inputs=lambda block: {"imu/data_raw", "gnss/fix", "gnss/vel"}, outputs=lambda block: ["nav/model_update"],
    enabled_by_default=True, ros_name="lever_arm_learning")
