"""Shared fixtures of the graph-level tests: one recorded short run of the
default scenario over real DDS, reused by several tests."""
import pathlib

import pytest

from hyper_nav_sim.graph import Graph
from hyper_nav_sim.report import load_run

SHORT = {"duration_s": 30.0, "report.skip_s": 10.0, "graph.real_time_factor": 2.0}


@pytest.fixture(scope="session")
def recorded_run(tmp_path_factory):
    bag = tmp_path_factory.mktemp("run") / "bag"
    with Graph("default", record=bag, overrides=SHORT, log_dir=bag.parent / "logs") as g:
        g.wait_until_done()
        scenario = g.scenario
    run = load_run(bag)
    run["bag"] = bag
    run["scenario"] = scenario
    return run


REPO = pathlib.Path(__file__).resolve().parents[1]
