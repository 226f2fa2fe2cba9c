"""The load harness's process tools (hyper_nav_workbench.load_harness): busy
processes at nice 0 that really use a CPU, a frozen process that really
stops (no CPU while stopped) and runs again, core lists."""
import os
import subprocess
import sys
import time

import pytest

from hyper_nav_workbench.load_harness import BusyProcesses, Throttle, freeze, parse_cores


def _cpu_s(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _state(pid: int) -> str:
    with open(f"/proc/{pid}/stat") as f:
        return f.read().rsplit(")", 1)[1].split()[0]


def test_parse_cores():
    assert parse_cores("0") == {0}
    assert parse_cores("0-0,0") == {0}
    with pytest.raises(ValueError, match="do not exist"):
        parse_cores(str(os.cpu_count() + 3))
    with pytest.raises(ValueError, match="no cores"):
        parse_cores(",")


def test_busy_processes_run_at_nice_0_and_use_cpu_until_stopped():
    with BusyProcesses(1, cores={0}) as busy:
        pid = busy.pids[0]
        assert os.getpriority(os.PRIO_PROCESS, pid) == 0
        assert os.sched_getaffinity(pid) == {0}
        c0 = _cpu_s(pid)
        t_end = time.monotonic() + 120.0              # only guards against a hang: any share counts
        while _cpu_s(pid) == c0 and time.monotonic() < t_end:
            time.sleep(0.1)
        assert _cpu_s(pid) - c0 > 0.0                  # it ran (any share: the machine may be busy)
    assert busy.procs == []
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def test_freeze_stops_a_process_then_resumes_it():
    """Ordered by events, not by sleeps (a busy machine may hold any thread
    for a second): the freeze lasts until the test has seen the process
    stopped and using no CPU, then it is released."""
    import threading
    p = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        release, out = threading.Event(), {}
        t = threading.Thread(target=lambda: out.setdefault("held", freeze(p.pid, 600.0, release)))
        t.start()
        t_end = time.monotonic() + 60.0
        while _state(p.pid) != "T" and time.monotonic() < t_end:
            time.sleep(0.01)
        cpu0 = _cpu_s(p.pid)
        time.sleep(0.5)
        state, cpu1 = _state(p.pid), _cpu_s(p.pid)
        release.set()
        t.join()
        assert state == "T" and cpu1 == cpu0                            # stopped: no CPU at all
        assert 0.5 <= out["held"] < 600.0                               # released, not timed out
        assert _state(p.pid) in ("R", "S")                               # running again
        with Throttle(p.pid, 0.2):
            time.sleep(0.3)
        assert _state(p.pid) in ("R", "S")                               # a throttle always leaves it running
    finally:
        p.kill()
        p.wait()
    assert freeze(p.pid, 0.1) == 0.0                                     # gone: not an error
