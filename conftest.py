"""Test-session wiring for the whole suite.

* ROS domain: each pytest process (each xdist worker) gets its own
  ``ROS_DOMAIN_ID`` unless one is set, before any test starts a node, so the
  graphs a test starts, the collectors it listens with and any graph another
  process runs on this machine never see each other's topics.
* ``make test`` runs the unit tests on two pytest-xdist workers (the machines
  have 2 cores) and then the tests that start node processes over DDS
  (marker ``graph``) in one process, one graph at a time, so no graph's
  real-time pacing competes with a second graph or a unit test. If graph
  tests run under xdist anyway, they all go to the same worker
  (``--dist loadgroup``).
"""
import os

import pytest

if not os.environ.get("ROS_DOMAIN_ID"):
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")          # "gw0", "gw1", ... under xdist
    base = 10 + (os.getpid() % 40) * 4                          # 10..166, spaced for 4 workers
    os.environ["ROS_DOMAIN_ID"] = str(base + (int(worker[2:]) if worker[2:].isdigit() else 0) % 4)


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.get_closest_marker("graph"):
            item.add_marker(pytest.mark.xdist_group("graph"))
