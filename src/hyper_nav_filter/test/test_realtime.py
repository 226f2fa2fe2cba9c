"""The fusion node's real-time settings (hyper_nav_filter.realtime, issue 35),
applied in a process of their own (never to the test process)."""
import json
import os
import struct
import subprocess
import sys

from hyper_nav_filter.core.params import ConfigError, check_all
from hyper_nav_filter.realtime import REALTIME_PARAMS, apply, hold_cpu_dma_latency

import pytest

CHILD = """
import json, os, sys, threading, time
from hyper_nav_filter.realtime import apply
ev = threading.Event()
th = threading.Thread(target=ev.wait); th.start()          # a thread that exists before, as DDS's do
problems = apply({"realtime.priority": 7})
late = []
t2 = threading.Thread(target=lambda: late.append(os.sched_getscheduler(0))); t2.start(); t2.join()
policies = {tid: os.sched_getscheduler(int(tid)) for tid in os.listdir("/proc/self/task")}
ev.set(); th.join()
print(json.dumps({"problems": problems, "policies": list(policies.values()), "late": late,
                  "prio": os.sched_getparam(0).sched_priority}))
"""


def test_priority_reaches_every_thread_or_says_why():
    out = json.loads(subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True,
                                    check=True).stdout)
    if out["problems"]:                       # no privilege here: the node runs on, and says why
        assert out["problems"][0].startswith("realtime.priority 7: not applied")
        assert set(out["policies"]) == {os.SCHED_OTHER}
    else:
        assert set(out["policies"]) == {os.SCHED_FIFO} and out["prio"] == 7
        assert out["late"] == [os.SCHED_FIFO]       # threads started later inherit it


def test_cpu_dma_latency_request_written_and_held(tmp_path):
    dev = tmp_path / "cpu_dma_latency"
    dev.write_bytes(b"")
    assert hold_cpu_dma_latency(25, str(dev)) is None
    assert struct.unpack("i", dev.read_bytes()) == (25,)
    assert "not applied" in hold_cpu_dma_latency(0, str(tmp_path / "missing" / "dev"))


def test_off_by_default_and_checked():
    defaults = {s.name: s.default for s in REALTIME_PARAMS}
    assert apply(defaults) == []
    with pytest.raises(ConfigError, match="realtime.priority"):
        check_all(REALTIME_PARAMS, {"realtime.priority": 120})
