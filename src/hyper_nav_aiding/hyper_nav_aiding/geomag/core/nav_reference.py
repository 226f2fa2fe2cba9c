"""The navigation solution to match a magnetometer sample against, chosen by
stamps alone, so the live node and an offline run pick the same one whatever
the order the two topics arrive in (issue 22).

The node keeps the recent ``nav/state`` solutions (``NavPoint``; one
publisher, so they arrive in stamp order). For a sample stamped t and a
reference lag L (``nav_reference_lag_s``: the fusion node's
``output_delay_s``, the age of its newest solution when the IMU reaches t):

* the decision waits until the first solution stamped after t - L has
  arrived (``next``): from then on no solution stamped at or before t - L
  can come, so the choice below cannot change with the arrival order;
* if ``next`` is stamped at or after t (L = 0: wait for the solution at t;
  or a hole in the solution stream), the solution at t is interpolated
  between the two that bracket it, if they are at most ``max_gap_s`` apart
  ("gap" otherwise);
* else the newest solution stamped at or before t - L is carried forward to
  t (``matching.predict_nav``; the live case), if it is at most
  ``max_prediction_s`` old ("stale" otherwise, and "gap" when it and
  ``next`` are more than ``max_gap_s`` apart).

"wait": the deciding solution has not come yet; "stale": the sample is older
than every kept solution or its reference too old.
"""
from __future__ import annotations

import bisect

from hyper_nav_aiding.geomag.core.matching import NavPoint, interpolate_nav, predict_nav

WAIT, STALE, GAP = "wait", "stale", "gap"


class NavReference:
    def __init__(self, max_gap_s: float, max_prediction_s: float, lag_s: float = 1.0, keep_s: float = 10.0):
        self.max_gap_s = max_gap_s
        self.max_prediction_s = max_prediction_s
        self.lag_s = lag_s
        self.keep_s = max(keep_s, 2.0 * lag_s + max_prediction_s)
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
        eps = 1e-9
        j = bisect.bisect_right(self._t, t_s - self.lag_s + eps)       # first solution after t - L
        if j == len(self._t):
            return None, WAIT
        nxt = self._nav[j]
        if nxt.t_s >= t_s - eps:                                       # bracketed (or exact)
            k = bisect.bisect_left(self._t, t_s - eps)
            b = self._nav[k]
            if abs(b.t_s - t_s) <= eps:
                return b, ""
            if k == 0:
                return None, STALE
            a = self._nav[k - 1]
            if b.t_s - a.t_s > self.max_gap_s:
                return None, GAP
            return interpolate_nav(a, b, t_s), ""
        if j == 0:
            return None, STALE
        ref = self._nav[j - 1]
        if nxt.t_s - ref.t_s > self.max_gap_s:
            return None, GAP
        if t_s - ref.t_s > self.max_prediction_s:
            return None, STALE
        return predict_nav(ref, t_s), ""
