"""Progress of long runs, one line every few seconds of wall time:
done/total, sim time, real-time factor and ETA (``make run``, replays,
reproduction commands, Monte Carlo campaigns). Plain text on stderr so that
a command's stdout (tables, JSON) stays clean; no ROS.

    p = Progress("replay_filter", total=300.0, unit="s sim")
    for ...:
        p.update(t_sim)              # prints when the interval has passed
    p.done()
"""
from __future__ import annotations

import sys
import time


def _hms(s: float) -> str:
    s = max(0.0, s)
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.1f} min"
    return f"{s / 3600:.1f} h"


class Progress:
    def __init__(self, label: str, total: float, unit: str = "s sim", interval_s: float = 5.0, stream=None,
                 clock=time.monotonic, sim: bool | None = None):
        """``total`` in ``unit``; with a sim-time unit the line shows the
        real-time factor (units done per wall second)."""
        self.label, self.total, self.unit = label, float(total), unit
        self.interval_s = interval_s
        self.stream = stream if stream is not None else sys.stderr
        self.clock = clock
        self.sim = ("sim" in unit) if sim is None else sim
        self.t0 = clock()
        self._last_print = self.t0
        self.value = self.v0 = 0.0          # v0: value at t0 (rates count from there)
        self.t_last = self.t0
        self.lines: list[str] = []

    def line(self, value: float) -> str:
        """The progress text at ``value`` (pure: used by update and tests)."""
        wall = max(self.clock() - self.t0, 1e-9)
        frac = min(max(value / self.total, 0.0), 1.0) if self.total > 0 else 1.0
        rate = (value - self.v0) / wall
        eta = (self.total - value) / rate if rate > 0 else float("inf")
        parts = [f"[{self.label}] {100 * frac:3.0f}%", f"{value:.1f}/{self.total:.1f} {self.unit}"]
        parts.append(f"{rate:.2f}x real time" if self.sim else f"{rate * 60:.1f} per min")
        parts.append(f"ETA {_hms(eta)}" if eta != float("inf") else "ETA -")
        return ", ".join(parts)

    def update(self, value: float, force: bool = False) -> None:
        self.value = float(value)
        now = self.t_last = self.clock()
        if force or now - self._last_print >= self.interval_s:
            self._last_print = now
            self._emit(self.line(self.value))

    def restart(self, value: float) -> None:
        """Count rates and ETA from now and ``value`` (e.g. after a start-up phase)."""
        self.t0 = self._last_print = self.t_last = self.clock()
        self.v0 = self.value = float(value)

    def done(self, extra: str = "") -> None:
        """The closing line: rate over the updates (start-up and shutdown excluded)."""
        wall = self.t_last - self.t0
        rate = (self.value - self.v0) / max(wall, 1e-9)
        self._emit(f"[{self.label}] done: {self.value:.1f} {self.unit} in {_hms(wall)} wall"
                   + (f", {rate:.2f}x real time" if self.sim else f", {rate * 60:.1f} per min")
                   + (f"; {extra}" if extra else ""))

    def _emit(self, text: str) -> None:
        self.lines.append(text)
        print(text, file=self.stream, flush=True)


class ClockProgress:
    """Progress of a running graph from its ``/clock`` (sim time), printed by
    ``run_graph`` while it waits: a background rclpy context of its own with
    one best-effort subscription (the time source does not wait for it)."""

    def __init__(self, domain_id: int, duration_s: float, label: str = "run_graph", interval_s: float = 10.0):
        self.domain_id, self.progress = domain_id, Progress(label, duration_s, interval_s=interval_s)
        self.t_sim = 0.0

    def __enter__(self) -> "ClockProgress":
        import threading

        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import qos_profile_sensor_data
        from rosgraph_msgs.msg import Clock
        self.context = rclpy.context.Context()
        rclpy.init(context=self.context, domain_id=self.domain_id)
        self.node = rclpy.create_node("run_graph_progress", context=self.context)
        self.node.create_subscription(Clock, "/clock", self._on_clock, qos_profile_sensor_data)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        return self

    def _on_clock(self, msg) -> None:
        first = self.t_sim == 0.0
        self.t_sim = msg.clock.sec + msg.clock.nanosec * 1e-9
        if first:
            self.progress.restart(self.t_sim)               # rate and ETA from the first tick (after start-up)
        else:
            self.progress.update(self.t_sim)

    def _spin(self) -> None:
        try:
            while self.context.ok():
                self.executor.spin_once(timeout_sec=0.2)
        except Exception:  # context shut down while spinning
            pass

    def __exit__(self, *exc) -> None:
        self.context.try_shutdown()
        self._thread.join(timeout=5)
        self.executor.shutdown()
        self.node.destroy_node()
        if self.t_sim > 0:
            self.progress.done()
