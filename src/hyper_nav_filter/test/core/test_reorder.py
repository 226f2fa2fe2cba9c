"""core.reorder.StampReorder: the released sequence is the stamp order for
any arrival order whose lateness stays within the window; what comes later
is released at once and counted."""
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hyper_nav_filter.core.reorder import StampReorder

MS = 1_000_000


def _arrivals(items, delays_ms):
    """Arrival order of (stamp_ns, tie, name) items, each delayed by its delay (ms)."""
    return [it for _, _, it in sorted((it[0] + d * MS, k, it) for k, (it, d) in enumerate(zip(items, delays_ms)))]


def _run(window_s, arrivals):
    r = StampReorder(window_s)
    out = []
    for t, tie, name in arrivals:
        out += r.push(t, tie, (t, tie, name))
    return out + r.flush(), r


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 5000), st.sampled_from(["imu", "gnss/fix", "gnss/vel"])), min_size=1,
                max_size=80),
       st.data())
def test_any_arrival_within_the_window_gives_the_stamp_order(raw, data):
    items = [(t * MS, tie, f"{tie}@{k}") for k, (t, tie) in enumerate(raw)]
    # one publisher per topic keeps its own order: same-topic same-stamp items stay in arrival order
    delays = data.draw(st.lists(st.integers(0, 400), min_size=len(items), max_size=len(items)))
    arr = _arrivals(items, delays)
    out, r = _run(0.5, arr)                      # window 500 ms > largest delay 400 ms
    ref, _ = _run(0.5, sorted(arr, key=lambda x: (x[0], x[1])))
    assert out == ref
    assert [x[:2] for x in out] == sorted(x[:2] for x in items)
    assert r.late == 0 and r.released == len(items) and len(r) == 0


def test_later_than_the_window_is_released_at_once_and_counted():
    r = StampReorder(0.1)
    out = []
    for t in (0, 10, 200, 300):                  # ms
        out += r.push(t * MS, "a", t)
    assert out == [0, 10, 200]                   # released once 100 ms behind the newest (300)
    assert r.push(50 * MS, "a", 50) == [50] and r.late == 1
    assert r.flush() == [300]


def test_bad_window_is_refused():
    for w in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="window_s"):
            StampReorder(w)


def test_shuffled_within_window_fixed_seed():
    rng = random.Random(3)
    items = [(t * 20 * MS, "imu", t) for t in range(200)] + [(t * 100 * MS, "fix", -t) for t in range(40)]
    arr = sorted(items, key=lambda x: x[0] + rng.uniform(0, 300) * MS)
    out, r = _run(0.35, arr)
    assert [x[2] for x in out] == [x[2] for x in sorted(items, key=lambda x: (x[0], x[1]))]
