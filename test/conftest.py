"""Shared fixtures of the graph-level tests: one recorded short run of the
default scenario over real DDS, reused by several tests. The antenna and
magnetometer sit off the IMU (so /tf_static has lever arms to check), and
the Foxglove live view runs with a WebSocket client attached (its messages
are in run["foxglove"])."""
import pathlib
import socket

import pytest

from hyper_nav_workbench.foxglove_client import FoxgloveClient
from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.report import load_run

LEVER_ARMS = {"gnss.antenna_lever_arm_b_m": [2.0, 0.0, 0.5], "filter.config.antenna_lever_arm_b_m": [2.0, 0.0, 0.5],
              "magnetometer.lever_arm_b_m": [-1.5, 0.0, 0.3]}
SHORT = {"duration_s": 30.0, "report.skip_s": 10.0, "graph.real_time_factor": 2.0, **LEVER_ARMS}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="session")
def recorded_run(tmp_path_factory):
    bag = tmp_path_factory.mktemp("run") / "bag"
    port = free_port()
    with Graph("default", record=bag, overrides=SHORT, log_dir=bag.parent / "logs",
               foxglove={"port": port}) as g, FoxgloveClient(f"ws://127.0.0.1:{port}") as fox:
        g.wait_until_done()
        scenario = g.scenario
    run = load_run(bag)
    run["bag"] = bag
    run["scenario"] = scenario
    run["foxglove"] = fox
    return run


REPO = pathlib.Path(__file__).resolve().parents[1]


# a user's own package's tests (test/plugin_packages/*/test) run inside the scratch install the fixture builds for
# them (test_user_guidance_fixture.py), not in this suite's collection: their package is not installed here
collect_ignore_glob = ["plugin_packages/*"]
