"""The node's parameters come from the scenario's lever_arm_learning block
(core.lever_arm.config); errors name the field."""
import pytest

from hyper_nav_aiding.lever_arm.core.config import LeverArmLearningConfig
from hyper_nav_sim.core.scenario import load_scenario


def test_seed000_elastic_block_gives_table3():
    lc = LeverArmLearningConfig.from_block(load_scenario("seed000_elastic").data["lever_arm_learning"])
    a = lc.reestimation.agent
    assert (a.actor_lr, a.critic_lr, a.episodes, a.steps, a.memory, a.tau, a.hidden) == \
        (0.001, 0.002, 50, 5, 250, 0.01, 30)
    assert lc.reestimation.method == "ddpg" and lc.reestimation.budget_passes == 250


@pytest.mark.parametrize("block, message", [
    ({"trigger": {"threshold_m": "three"}}, "lever_arm_learning.trigger.threshold_m: expected a number"),
    ({"trigger": {"threshold_m": 1.0, "release_m": 2.0}}, "lever_arm_learning.trigger.release_m"),
    ({"method": "sgd"}, "lever_arm_learning.method: expected one of"),
    ({"env": {"max_steps": 2.5}}, "lever_arm_learning.env.max_steps: expected an integer"),
    ({"windows_s": 3.0}, "lever_arm_learning.windows_s: unknown field .*did you mean 'window_s'"),
    ({"window_s": 0.1}, "lever_arm_learning.window_s: must be >= 0.5"),
])
def test_errors_name_the_field(block, message):
    with pytest.raises(ValueError, match=message):
        LeverArmLearningConfig.from_block(block)
