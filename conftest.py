"""Test-session wiring for the whole suite.

* ROS domain: each pytest process gets its own ``ROS_DOMAIN_ID`` before any
  test starts a node, so the graphs a test starts, the collectors it listens
  with and whatever else runs on this machine never see each other's topics.
  ``tools/run_tests.sh`` (``make test``) gives each lane its own domain; a
  bare ``pytest`` takes one derived from its pid; a pytest-xdist worker takes
  its master's domain + 1 + its index.
* Tests that start node processes over DDS (marker ``graph``) go to one
  xdist worker per test file (``--dist loadgroup``): a file's module-scoped
  graph (a recorded run, a scratch checkout) is started once, and graphs of
  two files may fly at once, each in its worker's own domain. ``make test``
  runs them in their own lane, one at a time (tools/run_tests.sh says why).
"""
import os

import pytest

_worker = os.environ.get("PYTEST_XDIST_WORKER", "")
if _worker[2:].isdigit():
    os.environ["ROS_DOMAIN_ID"] = str(int(os.environ.get("HYPER_NAV_TEST_DOMAIN", "40")) + 1 + int(_worker[2:]))
elif not os.environ.get("ROS_DOMAIN_ID"):
    os.environ["ROS_DOMAIN_ID"] = str(10 + (os.getpid() % 50) * 4)
os.environ.setdefault("HYPER_NAV_TEST_DOMAIN", os.environ["ROS_DOMAIN_ID"])


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.get_closest_marker("graph"):
            item.add_marker(pytest.mark.xdist_group(f"graph:{item.path.name}"))
