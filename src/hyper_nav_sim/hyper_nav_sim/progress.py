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
        self.value = 0.0
        self.lines: list[str] = []

    def line(self, value: float) -> str:
        """The progress text at ``value`` (pure: used by update and tests)."""
        wall = max(self.clock() - self.t0, 1e-9)
        frac = min(max(value / self.total, 0.0), 1.0) if self.total > 0 else 1.0
        rate = value / wall
        eta = (self.total - value) / rate if rate > 0 else float("inf")
        parts = [f"[{self.label}] {100 * frac:3.0f}%", f"{value:.1f}/{self.total:.1f} {self.unit}"]
        parts.append(f"{rate:.2f}x real time" if self.sim else f"{rate * 60:.1f} per min")
        parts.append(f"ETA {_hms(eta)}" if eta != float("inf") else "ETA -")
        return ", ".join(parts)

    def update(self, value: float, force: bool = False) -> None:
        self.value = float(value)
        now = self.clock()
        if force or now - self._last_print >= self.interval_s:
            self._last_print = now
            self._emit(self.line(self.value))

    def done(self, extra: str = "") -> None:
        wall = self.clock() - self.t0
        self._emit(f"[{self.label}] done: {self.value:.1f} {self.unit} in {_hms(wall)} wall"
                   + (f", {self.value / max(wall, 1e-9):.2f}x real time" if self.sim else "") + (f"; {extra}" if extra else ""))

    def _emit(self, text: str) -> None:
        self.lines.append(text)
        print(text, file=self.stream, flush=True)
