"""Test-session wiring for the whole suite.

* ROS domain: each pytest process gets its own ``ROS_DOMAIN_ID`` before any
  test starts a node, so the graphs a test starts, the collectors it listens
  with and whatever else runs on this machine never see each other's topics.
  ``tools/run_tests.sh`` (``make test``) gives each lane its own domain; a
  bare ``pytest`` takes one derived from its pid; a pytest-xdist worker takes
  its master's domain + 1 + its index.
* Tests that start node processes over DDS (marker ``graph``) go to one
  xdist worker per test file (``--dist loadfile`` in tools/run_tests.sh): a
  file's module-scoped graph (a recorded run, a scratch checkout) is started
  once, and graphs of two files may fly at once, each in its worker's own
  domain. ``make test`` runs them in their own lane (tools/run_tests.sh says
  why). (``--dist loadgroup`` with ``xdist_group`` markers would say the same,
  but pytest-xdist 3.8 cannot mark pytest 9.2's items: the markers are ignored.)
"""
import os

import pytest

_worker = os.environ.get("PYTEST_XDIST_WORKER", "")
if _worker[2:].isdigit():
    os.environ["ROS_DOMAIN_ID"] = str(int(os.environ.get("HYPER_NAV_TEST_DOMAIN", "40")) + 1 + int(_worker[2:]))
elif not os.environ.get("ROS_DOMAIN_ID"):
    os.environ["ROS_DOMAIN_ID"] = str(10 + (os.getpid() % 50) * 4)
os.environ.setdefault("HYPER_NAV_TEST_DOMAIN", os.environ["ROS_DOMAIN_ID"])


# --- CPU per test -------------------------------------------------------------
# ``--durations`` says where the wall time goes, which on a shared machine is
# mostly where the other lane was busy. The CPU a test used (this process and
# the processes it started and reaped: nodes, dask workers, commands) does not
# depend on the load: ``make test`` prints the top consumers at the end of each
# lane (``--cpu-top N``, 0 for none), also across pytest-xdist workers.
import resource  # noqa: E402


def _cpu_now() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def pytest_addoption(parser):
    parser.addoption("--cpu-top", type=int, default=0, help="print the N tests that used the most CPU")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    if call.when == "teardown":
        # setup + call + teardown so far (module fixtures land on the first test that uses them)
        report = outcome.get_result()
        report.user_properties.append(("cpu_s", _cpu_now() - item.config._hyper_nav_cpu_t0.get(item.nodeid, _cpu_now())))


def pytest_runtest_setup(item):
    item.config._hyper_nav_cpu_t0 = getattr(item.config, "_hyper_nav_cpu_t0", {})
    item.config._hyper_nav_cpu_t0[item.nodeid] = _cpu_now()


def pytest_runtest_logreport(report):
    if report.when == "teardown":
        for key, value in report.user_properties:
            if key == "cpu_s":
                _CPU_BY_TEST[report.nodeid] = value


_CPU_BY_TEST: dict = {}


def pytest_terminal_summary(terminalreporter, config):
    n = config.getoption("--cpu-top")
    if not n or not _CPU_BY_TEST or os.environ.get("PYTEST_XDIST_WORKER"):
        return
    total = sum(_CPU_BY_TEST.values())
    terminalreporter.section(f"CPU per test (this process + the processes it reaped), top {n} of {total / 60:.1f} CPU-min")
    for nodeid, cpu in sorted(_CPU_BY_TEST.items(), key=lambda kv: -kv[1])[:n]:
        terminalreporter.write_line(f"{cpu:8.1f} CPU-s  {100 * cpu / total:5.1f} %  {nodeid}")
