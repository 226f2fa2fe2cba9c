"""pytest fixture for a guidance node of your own in the loop (issue 36). Installing (building) the workspace
registers this module as a pytest plugin (``pytest11`` entry point ``hyper_nav_guidance``), beside the workbench's
(``hyper_nav_workbench.pytest_plugin``), whose ``hyper_nav_graph`` fixture it flies on.

Fixture:
  ``hyper_nav_guidance_loop``  factory for a guidance node of your own in the
      loop (issue 36): ``hyper_nav_guidance_loop(["ros2run-able", "cmd"] or
      ("pkg", "executable"), scenario="guidance_glide", nav_topic="truth/state")``
      starts the graph without the project's guidance node, your node with
      ``scenario:=<the run's scenario file>`` (it reads the ``guidance:`` block
      for the target), the truth node waiting for its commands
      (``hyper_nav_msgs/GlideCommand`` on ``guidance/command``, stamped with
      the navigation stamp they were computed from); returns a
      ``GuidanceRun``: ``miss`` (miss_m, down_range_m, cross_range_m at the
      target's altitude), ``bag`` (recorded), ``messages``, ``commands``,
      ``truth_node`` (its last /diagnostics: commands accepted / refused /
      missed) and ``replay_equal`` (the recorded bag's truth/state equals the
      flight its recorded guidance/command gives offline, bit for bit; the
      collected messages without ``record``). ``nav_topic="nav/state"`` (or
      any navigation topic) starts the sensor nodes and the fusion node as
      well: the sensors fly the steered flight (``flight/steps``), so your
      node flies on navigation of its own flight (tested with the project's
      guidance node in ``test/test_guidance_graph.py``). Your node should wait
      for its navigation input before anything else (the clock starts once
      its command publisher exists).

Nothing is imported from ROS until the fixture is used.
"""
from __future__ import annotations

import pathlib
from dataclasses import dataclass, field

import pytest

from hyper_nav_workbench.pytest_plugin import GraphFactory, GraphRun


@dataclass
class GuidanceRun:
    miss: dict
    bag: pathlib.Path | None
    messages: dict
    commands: list
    truth_node: dict
    replay_equal: bool
    run: GraphRun = field(repr=False)


class GuidanceLoop:
    """``hyper_nav_guidance_loop`` (module doc)."""

    def __init__(self, graphs: GraphFactory):
        self.graphs = graphs
        self.procs = []

    def __call__(self, node, scenario="guidance_glide", overrides: dict | None = None,
                 nav_topic: str = "truth/state", nav_type: str = "hyper_nav_msgs/msg/NavState",
                 record: bool = True, node_args=(), timeout_s: float | None = None) -> GuidanceRun:
        import signal
        import subprocess

        import numpy as np

        from hyper_nav_guidance.closed_loop import bag_loop, replay_equals
        from hyper_nav_filter.conversions import stamp_to_s
        from hyper_nav_workbench.graph import DEFAULT_NODES, executable
        if isinstance(node, tuple):
            from ament_index_python.packages import get_package_prefix
            node = [str(pathlib.Path(get_package_prefix(node[0])) / "lib" / node[0] / node[1])]
        # on truth/state the truth node alone; on a navigation topic the sensors and the fusion node too
        nodes = ["truth"] if nav_topic.lstrip("/") == "truth/state" else list(DEFAULT_NODES)
        topics = {"guidance/command": "hyper_nav_msgs/msg/GlideCommand", "truth/state": "hyper_nav_msgs/msg/NavState",
                  "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray"}
        if nav_topic not in topics:
            topics[nav_topic] = nav_type
        live = self.graphs.start(scenario, overrides, topics, record=record, nodes=tuple(nodes),
                                 extra_subscribers={nav_topic.lstrip("/"): 1},
                                 node_params={"truth": {"command_publishers": 1}})
        g = live.graph
        log = open(g.log_dir / "user_guidance.log", "w")
        cmd = list(node) + ["--ros-args", "-p", f"scenario:={g.scenario.path}", *node_args]
        executable("truth")                              # the workspace is built
        proc = subprocess.Popen(cmd, env=g.env(), stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        self.procs.append(proc)
        try:
            run = live.wait(timeout_s)
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
                try:
                    proc.wait(10.0)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
            log.close()
        cmds = sorted((stamp_to_s(m.header.stamp), m.bank_rad, m.c_l) for m in run.messages["guidance/command"])
        truth_node = {}
        for arr in run.messages["/diagnostics"]:
            for st in arr.status:
                if st.name == "hyper_nav_sim: truth":
                    truth_node = {kv.key: kv.value for kv in st.values}
        if run.bag is not None:               # on the recorded bag: its commands and its truth
            cmds, rows = bag_loop(run.bag)
        else:
            rows = np.array([[m.lat_rad, m.lon_rad, m.alt_m, *m.vel_enu_mps] for m in run.messages["truth/state"]])
        ok, replay = replay_equals(run.scenario, cmds, rows)
        return GuidanceRun(replay.miss, run.bag, run.messages, cmds, truth_node, ok, run)

    def close(self) -> None:
        for p in self.procs:
            if p.poll() is None:
                p.kill()
                p.wait()


@pytest.fixture
def hyper_nav_guidance_loop(hyper_nav_graph):
    """Factory: hyper_nav_guidance_loop(node_command or (pkg, exe), scenario=, overrides=, nav_topic=) flies
    the scenario with your guidance node in the loop; returns a GuidanceRun (miss, bag, commands, ...)."""
    loop = GuidanceLoop(hyper_nav_graph)
    yield loop
    loop.close()
