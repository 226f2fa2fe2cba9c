"""How far the simulated clock may run ahead of a recorder (its clock
allowance, ``hyper_nav_filter.clock_gate``), from what it has written.

A recorder behind its subscription queues loses messages once a queue is
deeper than its history (KEEP_LAST). Its node clock does not show that: with
``use_sim_time`` the clock is the newest ``/clock`` the time source
subscription took (a queue of one), not how far the recorder has worked
through its input. So the allowance follows the *pace stream* (the IMU, the
graph's fastest input, whose stamps follow the clock), by the header stamp of
its newest written message: ``stamp + lead_s``. A pace stream silent for
``gap_wall_s`` of wall time has nothing queued (a gap in the data, the end of
a bag, a dead sensor): the allowance then follows the node clock (``clock +
lead_s``), as it does before its first message.

Pure Python, no rclpy: ``nodes/recorder.py`` feeds it.
"""
from __future__ import annotations

import struct

_STAMP = struct.Struct("<iI")     # std_msgs/Header.stamp, right after the 4-byte CDR encapsulation header


def header_stamp_s(raw: bytes) -> float | None:
    """The header stamp (s) of a CDR message whose first field is a
    std_msgs/Header; None if the buffer is too short."""
    if len(raw) < 4 + _STAMP.size:
        return None
    sec, nsec = _STAMP.unpack_from(raw, 4)
    return sec + nsec * 1e-9


class RecordPace:
    """``written(stamp_s, wall_s)`` for every pace-stream message written;
    ``allowance_s(clock_s, wall_s)`` for the clock gate."""

    def __init__(self, lead_s: float, gap_wall_s: float = 1.0):
        self.lead_s = float(lead_s)
        self.gap_wall_s = float(gap_wall_s)
        self.newest_s: float | None = None
        self.wall_s = 0.0

    def written(self, stamp_s: float, wall_s: float) -> None:
        self.newest_s = stamp_s if self.newest_s is None else max(stamp_s, self.newest_s)
        self.wall_s = wall_s

    def allowance_s(self, clock_s: float, wall_s: float) -> float:
        if self.newest_s is None or wall_s - self.wall_s > self.gap_wall_s:
            return clock_s + self.lead_s
        return min(clock_s, self.newest_s) + self.lead_s
