"""Real-time settings of a node process, as a hardware-in-the-loop rig sets
them (issue 35): the scheduler of every thread, locked memory and the CPU's
wake-up latency. Off by default; each is a node parameter
(``REALTIME_PARAMS``), applied once at start by ``apply``.

* ``realtime.priority`` (1-99): SCHED_FIFO at this priority for every thread
  of the process, the middleware's receive threads included (they exist by
  the time a node is built; threads started later inherit it), as
  ros2_control's ``thread_priority`` does for its control loop.
* ``realtime.lock_memory``: ``mlockall(MCL_CURRENT | MCL_FUTURE)``, as
  ros2_control's ``lock_memory``: no page fault in a callback.
* ``realtime.cpu_dma_latency_us`` (>= 0): the Linux PM QoS request
  (``/dev/cpu_dma_latency``, held open while the process lives): the cores
  stay out of idle states slower to leave than this, so a message arriving
  after an idle gap does not wait for a core to wake (at a 200 Hz IMU the
  node idles about 4 of every 5 ms). It costs power, and on a virtual
  machine CPU time the host sees as busy.

Each needs the privilege (root or CAP_SYS_NICE / CAP_IPC_LOCK); without it
the node runs as before and says so once (``apply`` returns the messages).
No math here: operating-system calls only."""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import struct

from .core.params import BOOL, INT, ParamSpec

REALTIME_PARAMS = (
    ParamSpec("realtime.priority", INT, 0, "SCHED_FIFO priority (1-99) for every thread of the node's process, the "
              "middleware's included; 0: the normal scheduler", lo=0, hi=99),
    ParamSpec("realtime.lock_memory", BOOL, False, "lock the process's memory (mlockall current and future)"),
    ParamSpec("realtime.cpu_dma_latency_us", INT, -1, "hold the Linux PM QoS request /dev/cpu_dma_latency at this "
              "many microseconds while the node runs (0: cores never enter a slow idle state); -1: off",
              lo=-1, hi=1_000_000),
)

MCL_CURRENT, MCL_FUTURE = 1, 2
_held = []                    # the open /dev/cpu_dma_latency: the request lasts while it is open


def _threads() -> list[int]:
    return [int(t) for t in os.listdir("/proc/self/task")]


def set_fifo(priority: int) -> str | None:
    """SCHED_FIFO at ``priority`` for every thread now in the process; None or the reason it failed."""
    try:
        for tid in _threads():
            os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(priority))
    except (PermissionError, OSError) as exc:
        return f"realtime.priority {priority}: not applied ({exc})"
    return None


def lock_memory() -> str | None:
    libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
    if libc.mlockall(MCL_CURRENT | MCL_FUTURE) != 0:
        return f"realtime.lock_memory: not applied ({os.strerror(ctypes.get_errno())})"
    return None


def hold_cpu_dma_latency(us: int, path: str = "/dev/cpu_dma_latency") -> str | None:
    """Open the PM QoS device and write the request (a 32-bit integer, us); the
    file stays open (the kernel drops the request when it is closed)."""
    try:
        fd = os.open(path, os.O_WRONLY)
        os.write(fd, struct.pack("i", us))
    except OSError as exc:
        return f"realtime.cpu_dma_latency_us {us}: not applied ({exc})"
    _held.append(fd)
    return None


def apply(values: dict) -> list[str]:
    """Apply the ``realtime.*`` values (``declare_params`` of ``REALTIME_PARAMS``,
    names without the prefix or with it); the messages of those that could not
    be applied."""
    v = {k.removeprefix("realtime."): x for k, x in values.items()}
    out = []
    if v.get("lock_memory"):
        out.append(lock_memory())
    if v.get("cpu_dma_latency_us", -1) >= 0:
        out.append(hold_cpu_dma_latency(int(v["cpu_dma_latency_us"])))
    if v.get("priority", 0) > 0:
        out.append(set_fifo(int(v["priority"])))
    return [m for m in out if m]
