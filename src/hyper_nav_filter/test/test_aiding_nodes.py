"""Aiding nodes are declared, not wired (core/aiding_nodes.py): the installed
descriptors are read from their entry points, the scenario loader takes the
blocks and validators from them, the launcher the nodes, their wait counts
and parameters, and neither file names an aiding node."""
import pathlib
import re
import tempfile

import pytest

from hyper_nav_filter import aiding_nodes
from hyper_nav_sim.core import scenario
from hyper_nav_filter.aiding_nodes import AidingNode, flat_parameters
from hyper_nav_sim.core.scenario import ScenarioError, apply_overrides, load_scenario
from hyper_nav_workbench import graph as graph_module
from hyper_nav_workbench.graph import Graph

SIM = pathlib.Path(scenario.__file__).resolve().parents[1]


def test_the_installed_aiding_nodes_are_found_by_their_entry_points():
    nodes = aiding_nodes.descriptors()
    assert {"geomag", "virtual_gnss", "lever_arm"} <= set(nodes)
    assert all(isinstance(n, AidingNode) for n in nodes.values())
    assert set(aiding_nodes.by_block()) >= {"geomag", "virtual_gnss", "lever_arm_learning"}
    assert nodes["lever_arm"].ros_name == "lever_arm_learning"


def test_launcher_and_scenario_loader_name_no_aiding_node():
    """No block, executable or package of an installed aiding node in graph.py
    or core/scenario.py (node names that are also the simulator's own blocks,
    such as the elastic lever arm's ``lever_arm``, mean the simulator's model there)."""
    words = set()
    for n in aiding_nodes.descriptors().values():
        words |= {n.block, n.executable, n.package}
        if n.name not in scenario.OPTIONAL_BLOCKS:
            words.add(n.name)
    for path in (pathlib.Path(graph_module.__file__), SIM / "core" / "scenario.py"):
        text = path.read_text()
        found = sorted(w for w in words if re.search(rf"\b{re.escape(w)}\b", text))
        assert not found, f"{path.name} names aiding nodes: {found}"


def test_flat_parameters_and_the_start_rule():
    assert flat_parameters({"a": 1, "b": {"c": [1.0, 2.0], "d": "x"}, "skip": 3}, "blk", skip=("skip",)) == \
        {"blk.a": 1, "blk.b.c": [1.0, 2.0], "blk.b.d": "x"}
    assert flat_parameters({"a": {"b": 2}}) == {"a.b": 2}
    node = AidingNode("n", "pkg", "exe", "blk", validate=dict, parameters=lambda sc: {},
                      outputs=lambda b: [b.get("topic", "n/out")])
    assert not node.wanted({}, set())
    assert node.wanted({"blk": {"enabled": True}}, set())
    assert not node.wanted({"blk": {}}, set())                         # enabled_by_default False
    assert node.wanted({"blk": {"topic": "x/y"}}, {"x/y"})             # a fusion source takes its output
    assert node.wanted({}, {"n/out"})


def test_the_scenario_loader_validates_an_aiding_block_through_its_descriptor():
    sc = load_scenario("seed003_geomag")
    with pytest.raises(ScenarioError, match=r"geomag\.algorithm"):
        apply_overrides(sc, {"geomag.algorithm": "NOPE"}, pathlib.Path(tempfile.mkdtemp(prefix="aid_")))
    with pytest.raises(ScenarioError, match=r"virtual_gnss\.position_source"):
        apply_overrides(load_scenario("seed004_virtual"), {"virtual_gnss.position_source": "psychic"},
                        pathlib.Path(tempfile.mkdtemp(prefix="aid_")))


def test_the_launcher_starts_and_configures_aiding_nodes_from_their_descriptors():
    with_geomag = Graph("seed003_geomag")
    try:
        assert with_geomag.nodes[-1] == "geomag"                     # its output geomag/fix is a fusion source
        p = with_geomag._params("geomag")
        assert p["min_subscribers"] == 1 and p["qos.depth"] == 2000 and "geomag.algorithm" in p
        assert not any(k.startswith("geomag.reproduction") for k in p)
        assert with_geomag._params("mag")["min_subscribers"] == 1    # imu/mag waits for the geomag node
    finally:
        with_geomag._tmp.cleanup()
    without = Graph("seed003")                                       # a geomag block, no source takes its fixes
    try:
        assert "geomag" not in without.nodes
        assert without._params("mag")["min_subscribers"] == 0
    finally:
        without._tmp.cleanup()
    lever = Graph("seed000_elastic")
    try:
        assert "lever_arm" in lever.nodes
        p = lever._params("lever_arm")
        assert p["filter.state_blocks"] == ["att", "vel", "pos", "bg", "gm", "ba", "lev"] and "trigger.threshold_m" in p
        assert "lever_arm_learning" in lever._params("monitor")["nodes"]
    finally:
        lever._tmp.cleanup()


def test_each_sensor_topic_waits_for_its_own_consumers():
    """A subscriber of one topic of a sensor (here the user's, on gnss/fix) is
    waited for on that topic only: the node's other topics do not wait for it."""
    g = Graph("default", extra_subscribers={"gnss/fix": 1})
    try:
        p = g._params("gnss")
        assert p["min_subscribers"] == 2
        assert dict(zip(p["wait_topics"], p["wait_counts"])) == {"gnss/fix": 2, "gnss/vel": 1}
        assert "wait_topics" not in g._params("imu")
    finally:
        g._tmp.cleanup()
