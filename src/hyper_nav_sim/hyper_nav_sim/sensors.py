"""Sensor nodes, declared (STYLE pattern 20), as aiding nodes are
(``hyper_nav_filter.aiding_nodes``).

A package (this one for the IMU, GNSS, magnetometer, barometer and radar:
``nodes/descriptors.py``; a user's package for its own sensor) describes
each of its sensor nodes with one ``SensorNode`` and exports it through the
entry-point group ``hyper_nav.sensor_nodes``::

    entry_points={"hyper_nav.sensor_nodes": ["baro = hyper_nav_sim.nodes.descriptors:BARO"]}

The scenario loader (``core/scenario.py``) takes from it the scenario block
(its allowed keys and validator); the launcher (``hyper_nav_workbench.graph``)
its executable, ROS name, when it starts (always, or when its block is
there), its output topics and their nominal rates (the monitor's timeouts,
the subscriber counts its publishers wait for) and any further ROS
parameters; Monte Carlo (``hyper_nav_workbench.core.mc_sources``) its feed,
the messages the node publishes made by the node's own message code. None
of them names a sensor: a new one is its package's model, node and
descriptor, and a block in the scenario file. No rclpy here.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Callable, Iterable

GROUP = "hyper_nav.sensor_nodes"


def _no_parameters(sc, subscribers) -> dict:
    return {}


@dataclass(frozen=True)
class SensorNode:
    """One sensor node, as its package declares it.

    ``topics(scenario)`` gives the topics the node publishes for a validated
    ``Scenario``, each with its nominal rate (Hz, from the scenario): the
    monitor watches them. ``wait_topics(scenario)`` the topics whose
    publishers wait for their subscribers through the node's
    ``min_subscribers`` / ``wait_topics`` parameters (``sensor_base``; default:
    those of ``topics``). ``parameters(scenario, subscribers)`` any further
    ROS parameters (``subscribers(topics)``: how many subscriptions the
    launcher expects on them). ``fields()`` the allowed keys of its scenario
    block (None: the scenario's own schema holds them) and ``validate(block)``
    checks the block (raises ``ValueError`` naming the field as
    ``<block>.<field>``). ``replay_topics``: what a recorded run of it feeds a
    replay. ``mc_feed(scenario, trajectory)`` gives the messages the node
    publishes, as [(stamp_s, topic, message)] made by the node's own message
    code (Monte Carlo feeds them to the fusion sources on those topics);
    None: its messages are not drawn that way."""
    name: str                                   # the graph's process name (run_graph --nodes, logs)
    package: str                                # ament package of the executable
    executable: str
    block: str                                  # the scenario block that configures it
    topics: Callable[[object], dict]            # scenario -> {topic: nominal rate (Hz)}
    optional: bool = False                      # started only when its block is in the scenario
    order: int = 100                            # place among the sensor processes (start order, logs)
    ros_name: str | None = None                 # its ROS node name where it differs from ``name``
    wait_topics: Callable[[object], Iterable[str]] | None = None
    parameters: Callable[[object, Callable], dict] = _no_parameters
    fields: Callable[[], Iterable[str]] | None = None
    validate: Callable[[dict], object] | None = None
    replay_topics: tuple = ()
    latched_topics: tuple = ()                  # of replay_topics: sent once (transient local), not a periodic stream
    mc_feed: Callable | None = None

    def wanted(self, data: dict) -> bool:
        """Whether a scenario (validated mapping) runs this node."""
        return not self.optional or self.block in data

    def waited_topics(self, sc) -> list[str]:
        return list(self.wait_topics(sc) if self.wait_topics else self.topics(sc))


class DescriptorError(RuntimeError):
    """An installed descriptor is malformed or clashes with another; the message names the entry point."""


@functools.lru_cache(maxsize=None)
def descriptors() -> dict[str, SensorNode]:
    """Every installed sensor node by name (``GROUP`` entry points, loaded
    once), in their declared order."""
    out: dict[str, SensorNode] = {}
    for ep in sorted(entry_points(group=GROUP), key=lambda e: e.name):
        where = f"entry point {GROUP}:{ep.name} ({ep.value})"
        node = ep.load()
        if not isinstance(node, SensorNode):
            raise DescriptorError(f"{where}: expected a SensorNode, got {type(node).__name__}")
        if node.name in out:
            raise DescriptorError(f"{where}: node name '{node.name}' is declared twice")
        out[node.name] = node
    return dict(sorted(out.items(), key=lambda kv: (kv[1].order, kv[0])))


def by_block() -> dict[str, SensorNode]:
    """The installed sensor nodes by the scenario block each reads (several may share one)."""
    return {n.block: n for n in descriptors().values()}


def blocks() -> dict[str, list[SensorNode]]:
    out: dict[str, list[SensorNode]] = {}
    for n in descriptors().values():
        out.setdefault(n.block, []).append(n)
    return out


def stream_rates_hz(sc) -> dict:
    """Nominal rate of every topic the scenario's sensor nodes publish."""
    rates = {}
    for node in descriptors().values():
        if node.wanted(sc.data):
            rates.update({t: float(r) for t, r in node.topics(sc).items()})
    return rates
