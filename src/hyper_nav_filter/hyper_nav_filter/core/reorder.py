"""Stamp-order release of a message stream that arrives out of order by a
bounded amount (a reorder buffer with a watermark).

A consumer that pairs or windows several topics gives results that depend on
the arrival order unless it sees its inputs in stamp order. ``StampReorder``
holds what arrives and releases it in (stamp, tie) order once the newest stamp
seen is ``window_s`` past it: for any arrival order in which no item comes
more than ``window_s`` behind the newest stamp seen before it, the released
sequence is the same (the stamp order). An item that comes later than that,
behind what was already released, is released at once and counted
(``late``): the only case where the output can depend on the arrival order,
and it is reported. ``flush`` releases the rest (end of a bag, shutdown).

Ties: items of equal stamp are released by ``tie`` (e.g. the topic name),
then by arrival among equal (stamp, tie), which a single publisher keeps.
"""
from __future__ import annotations

import heapq
import math


class StampReorder:
    def __init__(self, window_s: float):
        if not (window_s >= 0.0 and math.isfinite(window_s)):
            raise ValueError(f"window_s: expected a finite number >= 0, got {window_s!r}")
        self.window_ns = int(round(window_s * 1e9))
        self._heap: list = []
        self._seq = 0
        self._newest_ns = None
        self._released_key = None
        self.late = 0                     # items that came behind what was already released
        self.released = 0

    def __len__(self) -> int:
        return len(self._heap)

    def push(self, stamp_ns: int, tie, item) -> list:
        """Add an item; returns the items released now, in stamp order."""
        key = (int(stamp_ns), tie)
        if self._released_key is not None and key < self._released_key:
            self.late += 1
            self.released += 1
            return [item]
        self._seq += 1
        heapq.heappush(self._heap, (key, self._seq, item))
        if self._newest_ns is None or stamp_ns > self._newest_ns:
            self._newest_ns = int(stamp_ns)
        return self._pop_until(self._newest_ns - self.window_ns)

    def flush(self) -> list:
        """Every item still held, in stamp order."""
        return self._pop_until(None)

    def _pop_until(self, limit_ns) -> list:
        out = []
        h = self._heap
        while h and (limit_ns is None or h[0][0][0] <= limit_ns):
            key, _, item = heapq.heappop(h)
            self._released_key = key
            out.append(item)
        self.released += len(out)
        return out
