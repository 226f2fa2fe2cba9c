"""The navigation solution to match a magnetometer sample against.

The node keeps the recent ``nav/state`` solutions (``NavPoint``, time
ordered) and, for a sample stamped t, takes

* the solution at t, interpolated between the two that bracket it (when the
  fusion node is ahead, e.g. replaying), if they are at most
  ``max_gap_s`` apart;
* else the newest solution carried forward to t (``matching.predict_nav``)
  if it is at most ``max_prediction_s`` old: the normal live case, since the
  fusion node releases its solutions ``output_delay_s`` behind;
* else nothing yet ("wait": the sample waits for its solution), or never
  ("stale": older than every kept solution; "gap": bracketing solutions too
  far apart).
"""
from __future__ import annotations

import bisect

from .matching import NavPoint, interpolate_nav, predict_nav

WAIT, STALE, GAP = "wait", "stale", "gap"


class NavReference:
    def __init__(self, max_gap_s: float, max_prediction_s: float, keep_s: float = 10.0):
        self.max_gap_s = max_gap_s
        self.max_prediction_s = max_prediction_s
        self.keep_s = keep_s
        self._t: list[float] = []
        self._nav: list[NavPoint] = []

    def add(self, nav: NavPoint) -> bool:
        """Keep a solution; False (not kept) when it is not newer than the newest."""
        if self._t and nav.t_s <= self._t[-1]:
            return False
        self._t.append(nav.t_s)
        self._nav.append(nav)
        k = bisect.bisect_left(self._t, nav.t_s - self.keep_s)
        if k:
            del self._t[:k], self._nav[:k]
        return True

    def at(self, t_s: float) -> tuple[NavPoint | None, str]:
        """(solution for t_s, "") or (None, WAIT | STALE | GAP)."""
        if not self._t:
            return None, WAIT
        i = bisect.bisect_left(self._t, t_s - 1e-9)
        if i < len(self._t):
            b = self._nav[i]
            if abs(b.t_s - t_s) <= 1e-9:
                return b, ""
            if i == 0:
                return None, STALE
            a = self._nav[i - 1]
            if b.t_s - a.t_s > self.max_gap_s:
                return None, GAP
            return interpolate_nav(a, b, t_s), ""
        newest = self._nav[-1]
        if t_s - newest.t_s <= self.max_prediction_s:
            return predict_nav(newest, t_s), ""
        return None, WAIT
