"""The lever-arm learning node, RL-DLAC (seed 000), declared to the launcher and the scenario loader (``hyper_nav_filter.aiding_nodes``; the
``hyper_nav.aiding_nodes`` entry point ``lever_arm`` in ``setup.py``): its executable, the scenario block it reads with
the block's validator, its inputs and outputs, and its ROS parameters from a scenario. The configuration modules are
imported when a block is validated or a node is started, not when the descriptor is read (every process that loads
a scenario reads it). No rclpy here.
"""
from __future__ import annotations

from hyper_nav_filter.aiding_nodes import AidingNode, filter_parameters, flat_parameters

PACKAGE = "hyper_nav_aiding"


# ---- lever-arm learning, RL-DLAC (seed 000) ----------------------------------------------
def _lever_arm_config(block: dict):
    from hyper_nav_aiding.lever_arm.core.config import LeverArmLearningConfig
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
