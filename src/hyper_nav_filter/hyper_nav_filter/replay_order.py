"""The order in which an offline replay feeds a recording's messages to the
fusion core, so that it reproduces the live fusion node bit for bit.

A bag's log order is the *recorder's* arrival order, not the fusion node's:
the two are separate subscribers, and under load one of them can receive a
GNSS fix a second after the IMU has passed its stamp while the other gets it
on time. Feeding the bag in log order therefore replays an arrival history
the live node never saw (issue 22: a fix that reached the recorder more than
``output_delay_s`` late was applied after its solution had been released in
the replay, and nowhere in the live run).

The fusion engine's solutions depend only on its inputs' stamps, except for
the messages it receives *behind* the IMU (stamp not newer than the newest
IMU sample when they arrive; the current-time stream, one state per IMU
sample, depends on exactly these): the fusion node reports each of those on
``nav/late_inputs`` (``hyper_nav_msgs/LateInput``: topic, stamp, occurrence,
the IMU stamp it followed, what the engine did with it). The replay order is

* every other message in stamp order (ties: topic name, then occurrence,
  so the order does not depend on the order the records are given in);
* each reported late message right after the IMU sample it followed in the
  live node, in the order the node reported them.

With no report (a bag recorded without ``nav/late_inputs``, or records that
never went through a live node) this is the stamp order: the on-time
solution, which is what the live node gives whenever nothing arrived behind
the IMU. Messages are duck-typed (rclpy or rosbags); no rclpy here.
"""
from __future__ import annotations

import bisect
from dataclasses import dataclass

LATE_INPUTS_TOPIC = "nav/late_inputs"


def stamp_ns(msg) -> int | None:
    """header.stamp in integer nanoseconds (None: the message has no header)."""
    h = getattr(msg, "header", None)
    if h is None:
        return None
    return int(h.stamp.sec) * 1_000_000_000 + int(h.stamp.nanosec)


def _time_ns(t) -> int:
    return int(t.sec) * 1_000_000_000 + int(t.nanosec)


@dataclass(frozen=True)
class LateInput:
    """One ``hyper_nav_msgs/LateInput`` report, in core form."""
    topic: str
    stamp_ns: int
    occurrence: int
    after_imu_ns: int
    outcome: str

    @classmethod
    def from_msg(cls, m) -> "LateInput":
        return cls(str(m.topic).lstrip("/"), stamp_ns(m), int(m.occurrence), _time_ns(m.after_imu_stamp),
                   str(m.outcome))


class LateInputTracker:
    """The live side: which arriving messages to report on
    ``nav/late_inputs`` (the fusion node calls ``arrival`` before handling a
    message and ``imu_accepted`` after an IMU sample was taken)."""

    def __init__(self):
        self.imu_ns: int | None = None            # stamp of the newest accepted IMU sample
        self._occurrence: dict[str, tuple] = {}   # topic -> (stamp, earlier messages with it)

    def arrival(self, topic: str, t_ns: int | None, drives_time: bool, last_released_s: float):
        """(report or None, applied after release): the report (outcome
        still to be set) when the message comes behind the IMU: an aiding
        message stamped at or before the newest IMU sample (at it: the
        current-time state of that sample did not see it, though the released
        solutions do not depend on it), an IMU sample not after it."""
        name = topic.lstrip("/")
        last, n = self._occurrence.get(name, (None, 0))
        n = n + 1 if t_ns == last else 0        # a publisher sends in order: equal stamps are adjacent
        self._occurrence[name] = (t_ns, n)
        if t_ns is None or self.imu_ns is None or not t_ns <= self.imu_ns:
            return None, False
        return LateInput(name, t_ns, n, self.imu_ns, ""), t_ns * 1e-9 <= last_released_s + 1e-9

    def imu_accepted(self, t_ns: int) -> None:
        self.imu_ns = int(t_ns)


@dataclass
class ReplayOrder:
    """The records to feed (``records``: (topic, message) pairs) and what was
    found on the way: late reports whose message is not among the records
    (``missing``, e.g. the recorder lost it) and the count of those placed."""
    records: list
    placed: int = 0
    missing: tuple = ()


def _keyed(records) -> list[tuple]:
    """(stamp_ns, topic, occurrence, index, topic, msg) for every record; a
    message without a stamp keeps the stamp of the record before it."""
    out, seen, last = [], {}, -(2**62)
    for i, (topic, msg) in enumerate(records):
        name = topic.lstrip("/")
        t = stamp_ns(msg)
        t = last if t is None else t
        last = t
        occ = seen.get((name, t), 0)
        seen[(name, t)] = occ + 1
        out.append((t, name, occ, i, topic, msg))
    return out


def live_order(records, late_inputs=(), imu_topic: str = "imu/data_raw") -> ReplayOrder:
    """The replay order of ``records`` ((topic, message) pairs, any order)
    given the live node's late-input reports (``LateInput`` or the messages;
    in the order the node published them)."""
    imu = imu_topic.lstrip("/")
    keyed = sorted(_keyed(records), key=lambda k: k[:3])
    where = {(k[1], k[0], k[2]): n for n, k in enumerate(keyed)}
    reports = [r if isinstance(r, LateInput) else LateInput.from_msg(r) for r in late_inputs]
    moved: dict[int, list[int]] = {}          # IMU stamp -> positions in `keyed` fed right after it
    taken, missing = set(), []
    for r in reports:
        n = where.get((r.topic, r.stamp_ns, r.occurrence))
        if n is None or n in taken:
            missing.append(r)
            continue
        taken.add(n)
        moved.setdefault(r.after_imu_ns, []).append(n)
    out = []
    if moved:
        # a report names the IMU sample it followed; when that sample is not in the
        # records, the message follows the newest IMU sample before that stamp
        imu_stamps = sorted(k[0] for k in keyed if k[1] == imu)
        anchored: dict[int, list[int]] = {}
        for t_imu, ns in sorted(moved.items()):
            j = bisect.bisect_right(imu_stamps, t_imu) - 1
            anchor = imu_stamps[j] if j >= 0 else None
            anchored.setdefault(anchor, []).extend(ns)
        head = anchored.pop(None, [])              # before the first IMU sample
        out.extend(keyed[n] for n in head)
        done_imu = set()
        for n, k in enumerate(keyed):
            if n in taken:
                continue
            out.append(k)
            if k[1] == imu and k[0] in anchored and k[0] not in done_imu:
                done_imu.add(k[0])
                out.extend(keyed[m] for m in anchored[k[0]])
    else:
        out = keyed
    return ReplayOrder([(k[4], k[5]) for k in out], len(taken), tuple(missing))


def split_late_inputs(records, topic: str = LATE_INPUTS_TOPIC) -> tuple[list, list]:
    """(input records, late-input reports) of records that may hold the
    node's ``nav/late_inputs`` messages among the inputs."""
    name = topic.lstrip("/")
    inputs, late = [], []
    for t, m in records:
        if t.lstrip("/") == name:
            late.append(m)
        else:
            inputs.append((t, m))
    return inputs, late
