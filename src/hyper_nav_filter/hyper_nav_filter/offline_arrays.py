"""The fusion core over a recording read into arrays (one array per message
field, ``hyper_nav_workbench.core.bag_arrays``), with the results of
``offline.run_offline`` over the same messages, bit for bit (tested), fed
in the same order (stamp order: a recording without late-input reports).

The IMU, which drives time and is nearly every message, goes straight to
``FusionEngine.add_imu_rates`` from its arrays (the IMU source's own
conversion: stamp ``sec + nanosec * 1e-9``, the rate vectors as they are
stored), with the source's counters kept as ``SourceType.on_message`` keeps
them; every other message goes through the declared sources
(``SourceRouter``) as in the live node, as a read-only view of its row
(``RowView``), so a converter sees what it sees live, or, for a source type
that converts column by column (``SourceType.prepare_rows``: the loosely
coupled GNSS fixes and velocities), as the item it made of that row, fed with
the counters ``on_message`` keeps (``on_prepared``). No rclpy here.

Topics are duck-typed: ``.topic``, ``.msgtype``, ``.fields`` ({dotted
path: array}), ``len()``, ``.t_ns`` and ``.seq`` (log time and file order)
and ``.stamp_ns``.
"""
from __future__ import annotations

import contextlib
import gc

import numpy as np

from .core import fusion_run
from .core.config import FilterConfig
from .core.fusion import FusionEngine, Solution
from .core.nav_state import NavState
from .sources import DEFAULT_TABLE
from .sources.base import SourceType
from .sources.router import SourceRouter


class RowView:
    """One message of a topic's arrays, read like a message object:
    ``view.header.stamp.sec``, ``view.position_covariance`` (the row of a
    (n, k) array), strings as str. Read-only. ``schema``: the topic's
    ``row_schema(fields)``, built once per topic (given, the view does no
    per-access search over the field names)."""
    __slots__ = ("_fields", "_row", "_prefix", "_schema")

    def __init__(self, fields: dict, row: int, prefix: str = "", schema: dict | None = None):
        self._fields, self._row, self._prefix = fields, row, prefix
        self._schema = row_schema(fields) if schema is None else schema

    def __getattr__(self, name):
        path = self._prefix + name
        kind = self._schema.get(path)
        if kind is None:
            raise AttributeError(name)
        if kind is _NESTED:
            return RowView(self._fields, self._row, path + ".", self._schema)
        v = kind[self._row]
        if isinstance(v, np.bytes_):
            return v.decode()
        return v.item() if isinstance(v, np.generic) else v

    def __getitem__(self, i):              # arrays of nested messages: view.status[0]
        return RowView(self._fields, self._row, f"{self._prefix[:-1]}.{i}.", self._schema)


_NESTED = object()


class MessageTopic:
    """A topic given as message objects rather than arrays (e.g. rosbags-
    deserialized ``hyper_nav_msgs/GnssMeasurements``, whose string sequence
    the field arrays split into one column per index and a row view cannot
    read back): duck-typed as a topic of arrays for the ordering (``t_ns``
    log times, ``seq`` log order, ``stamp_ns`` header stamps), fed through
    the declared sources one message at a time, as ``run_offline`` feeds
    it. ``messages`` in log order; every one has a header."""

    def __init__(self, topic: str, msgtype: str, messages: list, t_ns):
        self.topic, self.msgtype, self.messages = topic, msgtype, list(messages)
        self.t_ns = np.asarray(t_ns, np.int64)
        self.seq = np.arange(len(self.messages), dtype=np.int64)
        self.stamp_ns = np.array([int(m.header.stamp.sec) * 1_000_000_000 + int(m.header.stamp.nanosec)
                                  for m in self.messages], np.int64)
        self.fields: dict = {}

    def __len__(self) -> int:
        return len(self.messages)


def row_schema(fields: dict) -> dict:
    """{dotted path: its column, or _NESTED for every proper prefix of a
    field path} (``header``, ``header.stamp``, ``status.0``, ...)."""
    schema = {}
    for path in fields:
        parts = path.split(".")
        for i in range(1, len(parts)):
            schema.setdefault(".".join(parts[:i]), _NESTED)
    schema.update(fields)
    return schema


def log_order(topics) -> tuple[np.ndarray, np.ndarray]:
    """(topic index, row) of every message in log order (log time, ties in file order)."""
    which = np.concatenate([np.full(len(t), i, np.int64) for i, t in enumerate(topics)])
    row = np.concatenate([np.arange(len(t), dtype=np.int64) for t in topics])
    order = np.lexsort((np.concatenate([t.seq for t in topics]), np.concatenate([t.t_ns for t in topics])))
    return which[order], row[order]


def stamp_order(topics) -> tuple[np.ndarray, np.ndarray]:
    """(topic index, row) of every message in ``replay_order``'s stamp order: header stamp, then topic
    name without its leading '/', then occurrence (log order within a topic and stamp)."""
    names = [t.topic.lstrip("/") for t in topics]
    rank = {n: r for r, n in enumerate(sorted(names))}
    which = np.concatenate([np.full(len(t), i, np.int64) for i, t in enumerate(topics)])
    row = np.concatenate([np.arange(len(t), dtype=np.int64) for t in topics])
    stamp = np.concatenate([t.stamp_ns for t in topics])
    name_rank = np.array([rank[n] for n in names], np.int64)[which]
    order = np.lexsort((np.concatenate([t.seq for t in topics]), name_rank, stamp))
    return which[order], row[order]


ORDERS = {"stamp": stamp_order, "log": log_order}


def run_offline_arrays(topics, cfg: FilterConfig, initial: NavState, sources: dict | None = None,
                       final: bool = False, keep_history: bool = False, order: str = "stamp",
                       progress=None, keep_current: bool = False) -> tuple[list[Solution], FusionEngine, SourceRouter]:
    """``offline.run_offline`` over topic arrays: (solutions, engine, router).
    ``order``: ``"stamp"`` (default: ``run_offline``'s order for a recording
    without late-input reports, ``replay_order.live_order``) or ``"log"``
    (the bag's log order); ``progress(k)`` is called every 20,000 messages
    with the count fed so far. Late-input reports (``nav/late_inputs``) are
    not placed here: a recording that has them goes through ``run_offline``."""
    eng = FusionEngine(cfg, initial, keep_history=keep_history)
    eng.replay = None                          # as run_offline's: no ReplayOrder (no late inputs placed)
    eng.current_log = [] if keep_current else None     # (as run_offline's keep_current)
    router = SourceRouter(eng, sources or DEFAULT_TABLE)
    topics = [t for t in topics if t.topic.lstrip("/") in router.routes and len(t)]
    if not topics:
        return (list(eng.release(final=True)) if final else []), eng, router
    which, rows = ORDERS[order](topics)
    out: list[Solution] = []
    fast = []               # per topic: (topic, messages), (IMU source, stamps, rates, forces),
                            # (source, role, prepared items) or None (row views)
    schemas = [row_schema(t.fields) for t in topics]
    for t in topics:
        routes = router.routes[t.topic.lstrip("/")]
        src, role = routes[0]
        if isinstance(t, MessageTopic):
            fast.append((t.topic, t.messages))       # message objects, through the router as run_offline does
        elif len(routes) == 1 and src.drives_time and src.spec.type == "imu" and role == "main":
            f = t.fields
            stamp = f["header.stamp.sec"] + f["header.stamp.nanosec"] * 1e-9     # conversions.stamp_to_s
            w = np.column_stack([f[f"angular_velocity.{a}"] for a in "xyz"]).astype(float)
            a = np.column_stack([f[f"linear_acceleration.{a}"] for a in "xyz"]).astype(float)
            fast.append((src, stamp.tolist(), w, a, np.ascontiguousarray(stamp, dtype=np.float64)))
        elif len(routes) == 1 and not src.drives_time \
                and (items := src.prepare_rows(role, t.fields, len(t))) is not None:
            fast.append((src, role, items))          # converted column by column, fed one by one
        else:
            fast.append(None)
    hooks = [s for s in router.sources if type(s).on_imu is not SourceType.on_imu]    # sources waiting on the IMU
    counters = {}
    with _young_collections_only() as collect:
        _feed(eng, router, topics, fast, schemas, which, rows, hooks, counters, out, progress, collect)
    for src, n in counters.items():                # what SourceType.on_message counts per accepted sample
        src.counters["received main"] += n
        src.counters["processed main"] += n
    if final:
        out.extend(eng.release(final=True))
    return out, eng, router


GC_YOUNG_EVERY = 50_000          # messages between the replay's own young-generation collections


@contextlib.contextmanager
def _young_collections_only():
    """The replay loop without the interpreter's automatic collections, with
    a young-generation collection (``gc.collect(1)``) every GC_YOUNG_EVERY
    messages instead (``_feed``). A replay keeps every solution it releases,
    so the automatic full collections scan a heap that only grows: measured
    on the default 300 s bag, 0.58 s with them against 0.53 s without
    (least of three each, 15,000 epochs). The loop makes no cyclic garbage of
    its own (92 unreachable objects after a whole replay with collection
    off), so nothing piles up; the young collections bound what a source
    that did make cycles could hold. The collector's state is restored on
    exit, exceptions included."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield was                  # a caller that had turned collection off gets none
    finally:
        if was:
            gc.enable()


def _feed(eng, router, topics, fast, schemas, which, rows, hooks, counters, out, progress, collect) -> None:
    """Every message in the chosen order into the engine (see run_offline_arrays).
    Consecutive IMU samples (a run between two other messages) go through the
    engine's compiled run (``core.fusion_run``) while the engine is in its
    common case, from the first sample it cannot take on sample by sample
    (``add_imu_rates``), with the same results bit for bit; not when a source
    waits on every IMU sample (``on_imu``)."""
    add_imu = eng.add_imu_rates
    release = eng.release
    n = len(which)
    run_ok = not hooks and fusion_run.static_ok(eng)
    if run_ok:                                     # end (exclusive) of the run of one topic at each position
        starts = np.flatnonzero(np.diff(which)) + 1
        ends = np.append(starts, n)
        run_end = np.repeat(ends, np.diff(np.concatenate(([0], ends)))).tolist()
    which_l, rows_l = which.tolist(), rows.tolist()
    next_progress, next_collect = 0, GC_YOUNG_EVERY
    k = 0
    while k < n:
        i, r = which_l[k], rows_l[k]
        fi = fast[i]
        if fi is not None and len(fi) == 2:
            topic, messages = fi
            out.extend(router.handle_topic(topic, messages[r])[1])
        elif fi is not None and len(fi) == 3:
            src, role, items = fi
            src.on_prepared(role, items[r], eng)
        elif fi is not None:
            src, stamp, w, a, stamp_arr = fi
            taken = fusion_run.add_imu_rates_run(eng, stamp_arr, w, a, rows[k:run_end[k]]) if run_ok \
                and run_end[k] - k >= fusion_run.MIN_RUN else 0
            if taken:
                counters[src] = counters.get(src, 0) + taken
                out.extend(release())
                k += taken
            else:
                ok, reason = add_imu(stamp[r], w[r], a[r])
                if ok:
                    counters[src] = counters.get(src, 0) + 1
                else:
                    _count(src, reason)
                for s in hooks:
                    s.on_imu(eng)
                out.extend(release())
                k += 1
            if progress is not None and k > next_progress:
                progress(k - 1)
                next_progress = (k - 1) // 20000 * 20000 + 20000
            if collect and k >= next_collect:
                gc.collect(1)
                next_collect = k // GC_YOUNG_EVERY * GC_YOUNG_EVERY + GC_YOUNG_EVERY
            continue
        else:
            out.extend(router.handle_topic(topics[i].topic, RowView(topics[i].fields, r, schema=schemas[i]))[1])
        if progress is not None and k >= next_progress:
            progress(k)
            next_progress = k // 20000 * 20000 + 20000
        k += 1
        if collect and k >= next_collect:
            gc.collect(1)
            next_collect = k // GC_YOUNG_EVERY * GC_YOUNG_EVERY + GC_YOUNG_EVERY


def _count(src, reason: str) -> None:
    src.counters["received main"] += 1
    src.counters["rejected main"] += 1
    src.counters[f"rejected main: {reason.split(':')[0]}"] += 1
