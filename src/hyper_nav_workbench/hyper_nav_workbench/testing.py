"""Helpers for ROS-integrated tests of hyper-nav, in this suite or a user's.

``TopicCollector`` subscribes to topics from its own rclpy Context (Jazzy:
``rclpy.init`` is not a context manager, so each collector owns a Context
and shuts it down on exit) and spins in a background thread::

    with TopicCollector({"nav/odom": Odometry}, domain_id=g.domain_id) as c, g:
        g.wait_until_done()
    odoms = c.messages["nav/odom"]

Pair it with ``Graph(..., extra_subscribers={"nav/odom": 1})`` so the graph's
publishers wait for the collector before data flows. Use the graph's
``domain_id`` (set ROS_DOMAIN_ID before the collector starts).
"""
from __future__ import annotations

import os
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor

from hyper_nav_filter.ros_util import latched_qos, publisher_qos


class TopicCollector:
    def __init__(self, topics: dict, domain_id: int | None = None, depth: int = 2000, name: str = "collector",
                 latched=()):
        """``latched``: topics published transient-local (``/tf_static``,
        ``gnss/ephemeris``), subscribed so, to get what was sent before."""
        self.topics = dict(topics)
        self.latched = set(latched)
        self.domain_id = domain_id
        self.depth = depth
        self.name = name
        self.messages: dict[str, list] = {t: [] for t in self.topics}
        self._lock = threading.Lock()

    def __enter__(self) -> "TopicCollector":
        self.context = rclpy.context.Context()
        rclpy.init(context=self.context, domain_id=self.domain_id)
        self.node = rclpy.create_node(self.name, context=self.context)
        self.subscriptions = {}
        for topic, cls in self.topics.items():
            qos = latched_qos(self.depth) if topic in self.latched else publisher_qos(self.depth)
            self.subscriptions[topic] = self.node.create_subscription(cls, topic, self._callback(topic), qos)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        return self

    def _callback(self, topic):
        def cb(msg):
            with self._lock:
                self.messages[topic].append(msg)
        return cb

    def _spin(self):
        try:
            while self.context.ok():
                self.executor.spin_once(timeout_sec=0.1)
        except Exception:  # context shut down while spinning
            pass

    def publisher(self, cls, topic: str, depth: int = 2000):
        return self.node.create_publisher(cls, topic, publisher_qos(depth))

    def wait_matched(self, topics=None, timeout_s: float = 60.0) -> bool:
        """Wait until each subscription of ``topics`` (default: all) has
        matched at least one publisher *from this side*. A publisher counts
        a subscription as matched when it has discovered it, and may send
        before the subscription has matched it back: what it sends then is
        dropped (issue 22: at 50x, the first 5 s of a run's nav/state were
        lost this way). Start the data flowing after this returns True."""
        deadline = time.monotonic() + timeout_s
        subs = [self.subscriptions[t] for t in (topics or self.subscriptions)]
        while time.monotonic() < deadline:
            if all(s.get_publisher_count() >= 1 for s in subs):
                return True
            time.sleep(0.05)
        return False

    def wait_for(self, predicate, timeout_s: float = 30.0) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self._lock:
                if predicate(self.messages):
                    return True
            time.sleep(0.05)
        return False

    def __exit__(self, *exc) -> None:
        self.context.try_shutdown()
        self._thread.join(timeout=5)
        self.executor.shutdown()
        self.node.destroy_node()


def isolated_domain_id() -> int:
    """A ROS domain id for one test, away from the default 0: this process's
    own ``ROS_DOMAIN_ID`` when set (the project's conftest.py gives each test
    lane and xdist worker its own, and a worker runs one test at a time),
    else 100 + pid % 100 (a pid-derived id could land on another lane's
    domain under ``make test``)."""
    own = int(os.environ.get("ROS_DOMAIN_ID", "0") or 0)
    return own if own else 100 + os.getpid() % 100


def play_into_fusion(scenario: str, bag, topics, count: int, rate: float = 1.0, player_timeout_s: float = 180.0,
                     wait_s: float = 60.0, also: dict | None = None, latched=(), logs: dict | None = None) -> list:
    """Play ``topics`` of ``bag`` (the player, wall-clock paced at ``rate``
    and never ahead of what the fusion node allows, no /clock) into a live fusion node set up by ``scenario`` (a scenario
    name or YAML file) and return its first ``count`` ``nav/delayed/state`` messages (the released stream),
    to compare with ``hyper_nav_filter.offline.run_offline`` over the same
    bag (live == offline). Raises AssertionError with the node's log if the
    player fails or fewer than ``count`` solutions arrive within ``wait_s``.
    ``also``: {topic: type} collected as well, their messages put back in
    ``also`` (``latched``: those of them published transient local);
    ``logs``: filled with the player's and the fusion node's logs."""
    from hyper_nav_msgs.msg import NavState

    from hyper_nav_workbench.graph import Graph
    outputs = {"nav/delayed/state": NavState, **(also or {})}
    # paced by the fusion node's allowance too (hyper_nav_filter.clock_gate): on a loaded machine the
    # player waits for the node instead of overrunning its input queues (a fresh run under load lost data)
    player = {"bag": str(bag), "rate": float(rate), "topics": list(topics), "wait_for_subscribers": 1,
              "publish_clock": False, "allowance_nodes": ["fusion"]}
    with Graph(str(scenario), nodes=("fusion",), extra_subscribers={t: 1 for t in outputs if t not in latched}) as g:
        with TopicCollector(outputs, domain_id=g.domain_id, latched=latched) as c:
            # the fusion node's outputs matched from the collector's side before any input flows (else its
            # first solutions can be sent before the collector takes them: lost)
            assert c.wait_matched(["nav/delayed/state"]), "the fusion node's nav/delayed/state never matched the collector"
            g.node_params["player"] = player
            g._spawn("player")
            assert g.procs["player"].wait(timeout=player_timeout_s) == 0, g.log("player")
            enough = lambda m: len(m["nav/delayed/state"]) >= count       # noqa: E731
            if not _wait_quiet(c, enough, wait_s):
                # the node holds its last output_delay_s of solutions until newer IMU data come or it
                # stops: SIGINT, and it publishes them (publish_final_solutions), as the offline core
                # releases them at the end of the bag
                g.stop()
                c.wait_for(enough, wait_s)
            assert enough(c.messages), (len(c.messages["nav/delayed/state"]), count, g.log("fusion"))
            for t in also or {}:
                also[t] = list(c.messages[t])
            if logs is not None:
                logs.update({n: g.log(n) for n in ("player", "fusion")})
            return list(c.messages["nav/delayed/state"])[:count]


def _wait_quiet(c: TopicCollector, predicate, timeout_s: float, quiet_s: float = 3.0) -> bool:
    """Wait for ``predicate(c.messages)`` until ``timeout_s``, or until no
    new message came for ``quiet_s``; whether it holds."""
    deadline, last_n, last_change = time.monotonic() + timeout_s, -1, time.monotonic()
    while time.monotonic() < deadline:
        with c._lock:
            if predicate(c.messages):
                return True
            n = sum(len(v) for v in c.messages.values())
        if n != last_n:
            last_n, last_change = n, time.monotonic()
        elif time.monotonic() - last_change > quiet_s:
            return False
        time.sleep(0.05)
    return False
