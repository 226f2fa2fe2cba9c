"""Aiding nodes, declared (STYLE pattern 14, the navigation2 plugin list).

A node package above the simulator (geomagnetic matching, virtual GNSS,
lever-arm learning, a new receiver aid) describes each of its aiding nodes
with one ``AidingNode`` and exports it through the entry-point group
``hyper_nav.aiding_nodes``, as the pytest plugin is registered::

    entry_points={"hyper_nav.aiding_nodes": ["geomag = hyper_nav_aiding.geomag.descriptor:GEOMAG"]}

The scenario loader (``core/scenario.py``) takes from it the scenario block
the node reads and the block's validator; the launcher (``graph.py``) its
executable, when it starts (its block enables it, or a fusion source takes
one of its outputs), whose publishers wait for it (its inputs) and its ROS
parameters, which the descriptor writes from the scenario. Neither names an
aiding node: a new one is its package's descriptor, converter and node, and
a block in the scenario file. No rclpy here.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Callable, Iterable

GROUP = "hyper_nav.aiding_nodes"


def _no_topics(block: dict) -> tuple:
    return ()


@dataclass(frozen=True)
class AidingNode:
    """One aiding node, as its package declares it.

    ``validate(block)`` checks the scenario block (raises ``ValueError``
    naming the field as ``<block>.<field>``); ``parameters(scenario)`` gives
    the node's ROS parameters from a validated ``Scenario``; ``inputs(block)``
    the sensor topics it subscribes whose publishers wait for it (never
    ``nav/state``: the fusion node waits for one subscriber on each of its
    outputs, and no nav/state flows before the IMU, whose publisher waits for
    this node); ``outputs(block)`` the topics it publishes for the fusion
    node (a fusion source on one of them starts it). The launcher sets
    ``output_wait_parameter`` (if any) to the number of subscribers the
    outputs must see before the node takes its inputs. ``validate_scenario``
    checks the block against the rest of the scenario; ``gates_clock`` says
    the simulated clock waits for the node's allowance (its outputs are then
    never late, whatever the machine's load)."""
    name: str                                   # the graph's process name (run_graph --nodes, logs)
    package: str                                # ament package of the executable
    executable: str
    block: str                                  # the scenario block that configures it
    validate: Callable[[dict], object]
    parameters: Callable[[object], dict]
    inputs: Callable[[dict], Iterable[str]] = _no_topics
    outputs: Callable[[dict], Iterable[str]] = _no_topics
    enabled_by_default: bool = False            # started when its block is there without ``enabled``
    output_wait_parameter: str | None = None
    ros_name: str | None = None                 # its ROS node name where it differs from ``name``
    # the block against the whole validated scenario mapping (raises ValueError naming the fields)
    validate_scenario: Callable[[dict], object] | None = None
    # the time source waits for its /graph/allowance (hyper_nav_filter.clock_gate)
    gates_clock: bool = False
    # the node's logic in a Monte Carlo run (``core.mc_sources``), no rclpy: mc_feed(scenario, trajectory,
    # filter config, publish) -> an object with ``events()`` ([(stamp, feed(engine))]: its inputs, fed when
    # the run's IMU reaches their stamps) and ``released(engine, solutions)`` (the run's nav/state), which
    # sends its outputs with publish(engine, topic, message) to the fusion sources on that topic; None: its
    # outputs are not drawn in campaigns
    mc_feed: Callable | None = None

    def wanted(self, data: dict, fusion_inputs: set[str]) -> bool:
        """Whether a scenario (validated mapping) runs this node: its block
        enables it, or a fusion source takes one of its outputs."""
        block = data.get(self.block)
        if self.block in data and (block or {}).get("enabled", self.enabled_by_default):
            return True
        return bool(set(self.outputs(block or {})) & set(fusion_inputs))


class DescriptorError(RuntimeError):
    """An installed descriptor is malformed or clashes with another; the message names the entry point."""


@functools.lru_cache(maxsize=None)
def descriptors() -> dict[str, AidingNode]:
    """Every installed aiding node by name (``GROUP`` entry points, loaded once)."""
    out: dict[str, AidingNode] = {}
    blocks: dict[str, str] = {}
    for ep in sorted(entry_points(group=GROUP), key=lambda e: e.name):
        where = f"entry point {GROUP}:{ep.name} ({ep.value})"
        node = ep.load()
        if not isinstance(node, AidingNode):
            raise DescriptorError(f"{where}: expected an AidingNode, got {type(node).__name__}")
        if node.name in out:
            raise DescriptorError(f"{where}: node name '{node.name}' is declared twice")
        if node.block in blocks:
            raise DescriptorError(f"{where}: scenario block '{node.block}' is also node '{blocks[node.block]}''s")
        out[node.name] = node
        blocks[node.block] = node.name
    return out


def by_block() -> dict[str, AidingNode]:
    """The installed aiding nodes by the scenario block each reads."""
    return {n.block: n for n in descriptors().values()}


# ---- writing parameters from a scenario: the helpers every descriptor uses ----------------
def flat_parameters(block: dict, prefix: str = "", skip=()) -> dict:
    """A scenario block as dotted ROS parameters ({'geomag.magcom.area_cells':
    25} with prefix 'geomag'): the node declares and validates them (lists
    stay lists); keys in ``skip`` are left out."""
    out = {}
    for k, v in (block or {}).items():
        if k in skip:
            continue
        name = f"{prefix}.{k}" if prefix else str(k)
        if isinstance(v, dict):
            out.update(flat_parameters(v, name))
        else:
            out[name] = v
    return out


def filter_parameters(sc) -> dict:
    """The filter configuration as ROS parameters (``filter.<field>``), as the
    fusion node takes it; for nodes that run the filter's models too."""
    return {f"filter.{k}": v for k, v in sc.filter_config().as_dict().items()}


def output_deadline_s(sc) -> float:
    """An aiding output for epoch t must reach the fusion node before it
    releases t: while it is pending the clock waits at t + this (the fusion
    output delay minus 0.2 s; ``clock.deadline_s`` of the gated nodes)."""
    return max(0.1, float(sc.filter_config().output_delay_s) - 0.2)
