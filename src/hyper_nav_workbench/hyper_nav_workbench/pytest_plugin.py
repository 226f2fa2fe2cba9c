"""pytest fixtures for your own ROS tests of hyper-nav. Installing (building)
the workspace registers this module as a pytest plugin (``pytest11`` entry
point ``hyper_nav``), so a test file needs no conftest::

    from nav_msgs.msg import Odometry

    def test_my_flight(hyper_nav_graph):
        run = hyper_nav_graph("default", overrides={"duration_s": 6.0}, topics={"nav/odom": Odometry})
        assert len(run.messages["nav/odom"]) == 300

Fixtures:
  ``hyper_nav_graph``  factory: start the node graph on a scenario with
      overrides, collect the given topics (message class or "pkg/msg/Type")
      from the first message on, wait for the end of the flight, stop every
      node; returns a ``GraphRun`` (``messages``, ``bag`` when ``record``,
      ``scenario``, ``log(node)``). ``hyper_nav_graph.start(...)`` gives the
      running graph instead (a context manager) for tests that act while it
      flies. Anything still running is torn down when the test ends.
  (``hyper_nav_guidance_loop``, a guidance node of your own in the loop, is
  the guidance package's plugin: ``hyper_nav_guidance.pytest_plugin``.)
  ``hyper_nav_domain_id``  the ROS domain the fixture's graphs use
      (ROS_DOMAIN_ID, else one derived from the process id).

Nothing is imported from ROS until a fixture is used, so the plugin costs
nothing in test sessions that do not use it.
"""
from __future__ import annotations

import importlib
import os
import pathlib
from dataclasses import dataclass, field

import pytest

FUSION_OUTPUTS = ("nav/state", "nav/odom", "nav/fix")
TF_TOPICS = ("/tf", "/tf_static")
_OUTPUT_TYPES = {"nav/state": "hyper_nav_msgs/msg/NavState", "nav/odom": "nav_msgs/msg/Odometry",
                 "nav/fix": "sensor_msgs/msg/NavSatFix", "/tf": "tf2_msgs/msg/TFMessage",
                 "/tf_static": "tf2_msgs/msg/TFMessage"}


def message_class(t):
    """A message class, or one named "pkg/msg/Type" (or "pkg/Type")."""
    if not isinstance(t, str):
        return t
    parts = t.split("/")
    return getattr(importlib.import_module(f"{parts[0]}.msg"), parts[-1])


@dataclass
class GraphRun:
    scenario: object
    messages: dict
    bag: pathlib.Path | None
    graph: object = field(repr=False)

    def log(self, node: str) -> str:
        return self.graph.log(node)


class LiveGraph:
    """A started graph with its topic collector (``hyper_nav_graph.start``)."""

    def __init__(self, graph, collector, record, wanted):
        self.graph, self.collector, self.bag, self.wanted = graph, collector, record, tuple(wanted)
        self._open = True

    @property
    def messages(self) -> dict:
        """{topic: messages so far} of the topics asked for."""
        return {t: self.collector.messages[t] for t in self.wanted}

    @property
    def domain_id(self) -> int:
        return self.graph.domain_id

    def wait(self, timeout_s: float | None = None) -> GraphRun:
        """Wait for the end of the flight, stop the graph, return the run."""
        try:
            self.graph.wait_until_done(timeout_s)
        finally:
            self.close()
        return GraphRun(self.graph.scenario, self.messages, self.bag, self.graph)

    def close(self) -> None:
        if self._open:
            self._open = False
            try:
                self.graph.__exit__(None, None, None)          # stop every node, remove the params files
            finally:
                self.collector.__exit__(None, None, None)

    def __enter__(self) -> "LiveGraph":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class GraphFactory:
    def __init__(self, tmp_path: pathlib.Path, domain_id: int):
        self.tmp_path, self.domain_id = tmp_path, domain_id
        self.live: list[LiveGraph] = []

    def __call__(self, scenario="default", overrides: dict | None = None, topics: dict | None = None,
                 record: bool = False, nodes=None, foxglove: dict | None = None,
                 timeout_s: float | None = None) -> GraphRun:
        return self.start(scenario, overrides, topics, record, nodes, foxglove).wait(timeout_s)

    def start(self, scenario="default", overrides: dict | None = None, topics: dict | None = None,
              record: bool = False, nodes=None, foxglove: dict | None = None,
              extra_subscribers: dict | None = None, node_params: dict | None = None) -> LiveGraph:
        """Start the graph with a collector of ``topics`` already subscribed;
        publishers of those topics wait for it, so nothing is missed."""
        from hyper_nav_workbench.graph import Graph
        from hyper_nav_workbench.testing import TopicCollector
        wanted = {t: message_class(c) for t, c in (topics or {}).items()}
        subs = dict(wanted)
        if any(t in FUSION_OUTPUTS for t in wanted):        # fusion starts when every output has a subscriber
            subs.update({t: message_class(_OUTPUT_TYPES[t]) for t in FUSION_OUTPUTS if t not in subs})
        if any(t in TF_TOPICS for t in wanted):
            subs.update({t: message_class(_OUTPUT_TYPES[t]) for t in TF_TOPICS if t not in subs})
        extra = {t: 1 for t in subs if t != "/tf_static"}
        for t, k in (extra_subscribers or {}).items():          # subscribers of your own besides the collector
            extra[t] = extra.get(t, 0) + k
        n = len(self.live)
        bag = self.tmp_path / f"run{n}" / "bag" if record else None
        g = Graph(scenario, record=bag, nodes=nodes, overrides=overrides, extra_subscribers=extra,
                  log_dir=self.tmp_path / f"run{n}" / "logs", domain_id=self.domain_id, foxglove=foxglove,
                  node_params=node_params)
        collector = TopicCollector(subs, domain_id=self.domain_id, latched=("/tf_static",)).__enter__()
        live = LiveGraph(g, collector, bag, wanted)
        self.live.append(live)
        try:
            g.start()
        except Exception:
            live.close()
            raise
        return live

    def close(self) -> None:
        for live in self.live:
            live.close()


@pytest.fixture
def hyper_nav_domain_id() -> int:
    """The ROS domain of the fixture's graphs: ROS_DOMAIN_ID, else 100 + pid % 100."""
    env = os.environ.get("ROS_DOMAIN_ID")
    return int(env) if env else 100 + os.getpid() % 100


@pytest.fixture
def hyper_nav_graph(tmp_path, hyper_nav_domain_id):
    """Factory: hyper_nav_graph(scenario, overrides=, topics=, record=, nodes=, foxglove=) runs a flight and
    returns a GraphRun (messages, bag, scenario, log); .start(...) gives the running graph."""
    factory = GraphFactory(tmp_path, hyper_nav_domain_id)
    yield factory
    factory.close()
