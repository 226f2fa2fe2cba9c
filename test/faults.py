"""Fault-injection helpers for the graph tests: run ``run_graph`` as a user
would, find its node processes, kill them, doctor a recorded bag."""
from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import time

import numpy as np
from ament_index_python.packages import get_package_prefix

from hyper_nav_workbench.core.bag import BagWriter, deserialize, read_bag, serialize
from hyper_nav_workbench.graph import executables

EXE_TO_NODE = {exe: name for name, (_pkg, exe) in executables().items()}


def command(pkg: str, exe: str) -> str:
    return os.path.join(get_package_prefix(pkg), "lib", pkg, exe)


class RunGraph:
    """``run_graph`` as a subprocess (stdout/stderr to files in ``workdir``)."""

    def __init__(self, workdir: pathlib.Path, *args: str):
        self.workdir = pathlib.Path(workdir)
        self.out_path, self.err_path = self.workdir / "run_graph.out", self.workdir / "run_graph.err"
        self.proc = subprocess.Popen([command("hyper_nav_workbench", "run_graph"), *args],
                                     stdout=self.out_path.open("w"), stderr=self.err_path.open("w"))

    def children(self) -> dict[str, int]:
        """Node name -> pid of run_graph's node processes (from /proc)."""
        out = {}
        for stat in pathlib.Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
                if int(fields[1]) != self.proc.pid:
                    continue
                cmd = (stat.parent / "cmdline").read_bytes().split(b"\0")
            except (OSError, IndexError, ValueError):
                continue
            for part in cmd:
                name = EXE_TO_NODE.get(os.path.basename(part.decode(errors="replace")))
                if name and "/lib/" in part.decode(errors="replace"):
                    out[name] = int(stat.parent.name)
        return out

    def wait_for_log(self, log_dir: pathlib.Path, node: str, text: str, timeout_s: float = 90.0) -> float:
        """Wait until ``text`` appears in a node's log; the wall time then."""
        deadline = time.monotonic() + timeout_s
        path = log_dir / f"{node}.log"
        while time.monotonic() < deadline:
            if path.is_file() and text in path.read_text(errors="replace"):
                return time.monotonic()
            assert self.proc.poll() is None, self.output()
            time.sleep(0.05)
        raise AssertionError(f"'{text}' not in {path} after {timeout_s} s\n{self.output()}")

    def sleep_until(self, wall_s: float) -> None:
        while (left := wall_s - time.monotonic()) > 0:
            time.sleep(min(left, 0.05))

    def kill(self, node: str, sig=signal.SIGKILL) -> int:
        pid = self.children()[node]
        os.kill(pid, sig)
        return pid

    def wait(self, timeout_s: float = 240.0) -> int:
        try:
            return self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.send_signal(signal.SIGINT)
            self.proc.wait(timeout=60)
            raise AssertionError(f"run_graph did not finish within {timeout_s} s\n{self.output()}")

    def output(self) -> str:
        return self.out_path.read_text(errors="replace") + "\n--- stderr ---\n" + \
            self.err_path.read_text(errors="replace")

    @property
    def stdout(self) -> str:
        return self.out_path.read_text(errors="replace")

    @property
    def stderr(self) -> str:
        return self.err_path.read_text(errors="replace")


def alive(pids) -> list[int]:
    """The pids that still exist (not zombies of an exited parent)."""
    out = []
    for pid in pids:
        try:
            state = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            out.append(pid)
    return out


def report_json(bag: pathlib.Path) -> dict:
    return json.loads((bag / "report.json").read_text())


def statuses(bag: pathlib.Path) -> dict[str, list]:
    """Every recorded /diagnostics status: name -> [(t, level, message, values)]."""
    from hyper_nav_workbench.report import load_run
    return load_run(bag)["timeline"]


def stamp(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def doctor_bag(src, dst, *, nan_s=(), duplicate_s=(), swap_s=(), imu_gap_s=None, gnss_stop_s=None,
               topics=("/imu/data_raw", "/gnss/fix", "/gnss/vel", "/truth/state"), cut_fraction=None) -> dict:
    """A copy of a recorded bag with input faults, logged on sim time (log
    time = header stamp), with the source's scenario.yaml:

    nan_s: IMU epochs whose rates become NaN; duplicate_s: IMU epochs sent
    three times; swap_s: IMU epochs sent after the next one (reversed pair);
    imu_gap_s: (t0, t1) IMU epochs in (t0, t1] dropped; gnss_stop_s: no
    gnss/fix or gnss/vel after it; cut_fraction: the MCAP cut to this
    fraction of its size and metadata.yaml removed (a recorder killed while
    writing). Returns the counts of each fault as written."""
    src, dst = pathlib.Path(src), pathlib.Path(dst)
    key = lambda t: round(t * 1000)  # noqa: E731  (ms)
    nan, dup, swap = {key(t) for t in nan_s}, {key(t) for t in duplicate_s}, {key(t) for t in swap_s}
    records = [r for r in read_bag(src) if r.topic in topics]
    out, held, counts = [], None, {"nan": 0, "duplicates": 0, "swapped": 0, "gap": 0, "gnss_dropped": 0}
    for r in records:
        msg = deserialize(r.raw, r.msgtype)
        t = stamp(msg)
        if r.topic in ("/gnss/fix", "/gnss/vel") and gnss_stop_s is not None and t > gnss_stop_s + 1e-9:
            counts["gnss_dropped"] += 1
            continue
        if r.topic != "/imu/data_raw":
            out.append((r.topic, r.msgtype, t, r.raw))
            continue
        if imu_gap_s and imu_gap_s[0] + 1e-9 < t <= imu_gap_s[1] + 1e-9:
            counts["gap"] += 1
            continue
        raw = r.raw
        if key(t) in nan:
            msg.angular_velocity.x = float("nan")
            raw = serialize(msg, r.msgtype)
            counts["nan"] += 1
        if key(t) in swap:
            held = (r.topic, r.msgtype, t, raw)
            counts["swapped"] += 1
            continue
        out.append((r.topic, r.msgtype, t, raw))
        if key(t) in dup:
            out += [(r.topic, r.msgtype, t, raw)] * 2
            counts["duplicates"] += 2
        if held is not None:                      # the earlier epoch after the later one
            out.append(held[:2] + (t, held[3]))
            held = None
    qos = read_bag(src).qos
    with BagWriter(dst) as w:
        for topic in {o[0] for o in out}:
            w.add_topic(topic, next(o[1] for o in out if o[0] == topic), qos.get(topic, []))
        for topic, msgtype, t, raw in out:
            w.write(topic, msgtype, int(round(t * 1e9)), raw)
    if (src / "scenario.yaml").is_file():
        (dst / "scenario.yaml").write_text((src / "scenario.yaml").read_text())
    counts["imu"] = sum(1 for o in out if o[0] == "/imu/data_raw")
    if cut_fraction is not None:
        mcap = next(dst.glob("*.mcap"))
        data = mcap.read_bytes()
        mcap.write_bytes(data[: int(len(data) * cut_fraction)])
        (dst / "metadata.yaml").unlink()
        counts["imu_readable"] = sum(1 for r in read_bag(dst) if r.topic == "/imu/data_raw")
    return counts


def nav_longitudes_deg(bag) -> dict[str, np.ndarray]:
    """Longitudes of every message that carries one, per topic."""
    out: dict[str, list] = {}
    for r in read_bag(bag):
        topic = r.topic.lstrip("/")
        if topic in ("nav/state", "truth/state"):
            out.setdefault(topic, []).append(np.degrees(deserialize(r.raw, r.msgtype).lon_rad))
        elif topic in ("nav/fix", "gnss/fix"):
            out.setdefault(topic, []).append(deserialize(r.raw, r.msgtype).longitude)
    return {k: np.array(v) for k, v in out.items()}
