"""This package's aiding nodes, declared to the launcher and the scenario
loader (``hyper_nav_filter.aiding_nodes``; the ``hyper_nav.aiding_nodes``
entry points in ``setup.py``). Each names its executable, the scenario block
it reads with the block's validator, its inputs and outputs, and writes its
ROS parameters from a scenario with the same helpers (``flat_parameters``,
``filter_parameters``). The configuration modules are imported when a block
is validated or a node is started, not when the descriptors are read (every
process that loads a scenario reads them). No rclpy here.
"""
from __future__ import annotations

from hyper_nav_filter.aiding_nodes import AidingNode, filter_parameters, flat_parameters, output_deadline_s

PACKAGE = "hyper_nav_aiding"


# ---- virtual GNSS (seed 004 section 2.3) ------------------------------------------------
def _virtual_gnss_config(block: dict):
    from .core.virtual_gnss_config import VirtualGnssConfig
    return VirtualGnssConfig.from_config(block)


def _virtual_gnss_parameters(sc) -> dict:
    from .parameters import from_scenario
    return {**from_scenario(sc), "clock.deadline_s": output_deadline_s(sc)}


def _virtual_gnss_inputs(block: dict) -> set[str]:
    alpha_beta = (block or {}).get("position_source") == "alpha_beta"
    return {"gnss/raw", "gnss/ephemeris", "imu/data_raw"} | ({"gnss/fix"} if alpha_beta else set())


VIRTUAL_GNSS = AidingNode(
    name="virtual_gnss", package=PACKAGE, executable="virtual_gnss_node", block="virtual_gnss",
    validate=_virtual_gnss_config, parameters=_virtual_gnss_parameters, inputs=_virtual_gnss_inputs,
    outputs=lambda block: [_virtual_gnss_config(block).topic], output_wait_parameter="min_output_subscribers",
    gates_clock=True)


# ---- geomagnetic matching (seed 003) -----------------------------------------------------
def _geomag_config(block: dict):
    from .core.geomag_config import GeomagConfig
    return GeomagConfig.from_dict(block)


def _geomag_map_epoch(data: dict):
    from .core.map_epoch import check_scenario
    return check_scenario(data)


def _geomag_parameters(sc) -> dict:
    # the block's ``reproduction`` part configures the offline reproduction only
    p = {**flat_parameters(sc.data.get("geomag") or {}, "geomag", skip=("reproduction",)),
         "qos.depth": int(sc["graph.qos_depth"]),
         # the flight's date: the node checks its map's epoch against it (issue 27)
         "magnetometer.epoch_decimal_year": float(sc["magnetometer.epoch_decimal_year"]),
         "clock.deadline_s": output_deadline_s(sc)}
    # a sample is matched against a solution released a second before it is taken (by stamps, not by
    # arrival): the fix is made when the sample comes and reaches the filter before its release
    p.setdefault("geomag.nav_reference_lag_s", float(sc.filter_config().output_delay_s) + 1.0)
    return p


def _geomag_mc_feed(sc, traj, cfg, publish):
    from .mc_geomag import mc_feed
    return mc_feed(sc, traj, cfg, publish)


GEOMAG = AidingNode(
    name="geomag", package=PACKAGE, executable="geomag_node", block="geomag",
    validate=_geomag_config, parameters=_geomag_parameters,
    inputs=lambda block: {"imu/mag"}, outputs=lambda block: ["geomag/fix"], output_wait_parameter="min_subscribers",
    validate_scenario=_geomag_map_epoch, gates_clock=True, mc_feed=_geomag_mc_feed)


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
    inputs=lambda block: {"imu/data_raw", "gnss/fix", "gnss/vel"} | ({block["load_topic"]} if block.get("load_topic")
                                                                     else set()),
    outputs=lambda block: ["nav/model_update"],
    enabled_by_default=True, ros_name="lever_arm_learning", gates_clock=True)
