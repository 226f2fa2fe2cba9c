"""clock_gate's readiness (real rclpy, two participants in one process): a
node's input subscription counts as matched only when the node's own side
has matched the publisher; its allowance is published only from then on;
a publisher that can never match (incompatible QoS) does not hold the gate
for longer than the timeout; a time source's not-heard timeout counts from
its restart (issue 22: the walk replay lost its first solutions between
nodes matched on one side only, and to a player that had dropped the fusion
node from its gate before it started)."""
import time

import pytest
import rclpy
from diagnostic_msgs.msg import KeyValue
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu

from hyper_nav_filter.clock_gate import TOPIC, AllowanceGate, ClockAllowance, DrainPace, InputDrain, InputsIdle, InputsReady
from hyper_nav_workbench.testing import isolated_domain_id

RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE)
BEST_EFFORT = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)


@pytest.fixture
def two_participants():
    domain = isolated_domain_id()          # 100-199: Fast DDS takes ids up to 232 (ports)
    ctxs, nodes, execs = [], [], []
    for name in ("subscriber_side", "publisher_side"):
        ctx = rclpy.context.Context()
        rclpy.init(context=ctx, domain_id=domain)
        node = rclpy.create_node(name, context=ctx)
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        ctxs.append(ctx), nodes.append(node), execs.append(ex)
    yield nodes, execs
    for node, ex, ctx in zip(nodes, execs, ctxs):
        ex.shutdown()
        node.destroy_node()
        ctx.try_shutdown()


def _spin_until(execs, predicate, timeout_s):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        for ex in execs:
            ex.spin_once(timeout_sec=0.01)
        if predicate():
            return True
    return False


@pytest.mark.graph
def test_ready_only_once_the_subscriber_side_has_matched_the_publisher(two_participants):
    (sub_node, pub_node), execs = two_participants
    subs = []
    ready = InputsReady(sub_node, lambda: subs, required=["imu/data_raw"], timeout_s=60.0)
    assert not ready()                                        # no subscription yet
    subs.append(sub_node.create_subscription(Imu, "imu/data_raw", lambda m: None, RELIABLE))
    assert not ready() and ready.unmatched() == ["/imu/data_raw (0 of 1 publishers matched)"]
    heard = []
    sub_node.create_subscription(KeyValue, TOPIC, heard.append, RELIABLE)
    flag = [False]
    allowance = ClockAllowance(pub_node, ready=lambda: flag[0])
    allowance.set(12.5)
    _spin_until(execs, lambda: False, 0.3)
    assert heard == [] and allowance._sent is None            # not ready: nothing published, timer or set
    pub_node.create_publisher(Imu, "imu/data_raw", RELIABLE)
    assert _spin_until(execs, ready, 20.0), ready.unmatched()
    assert subs[0].get_publisher_count() == 1
    flag[0] = True
    assert _spin_until(execs, lambda: heard, 20.0)
    assert heard[0].key == "publisher_side" and float(heard[0].value) == 12.5


@pytest.mark.graph
def test_a_publisher_that_never_matches_holds_the_gate_only_until_the_timeout(two_participants):
    (sub_node, pub_node), execs = two_participants
    sub = sub_node.create_subscription(Imu, "imu/data_raw", lambda m: None, RELIABLE)
    pub_node.create_publisher(Imu, "imu/data_raw", BEST_EFFORT)    # reliable reader, best-effort writer: never
    ready = InputsReady(sub_node, lambda: [sub], timeout_s=1.0)
    assert _spin_until(execs, lambda: sub_node.count_publishers("/imu/data_raw") == 1, 20.0)
    t0 = time.monotonic()
    assert not ready() and ready.unmatched() == ["/imu/data_raw (0 of 1 publishers matched)"]
    assert _spin_until(execs, ready, 20.0)
    assert time.monotonic() - t0 >= 1.0 and sub.get_publisher_count() == 0


@pytest.mark.graph
def test_the_gate_counts_its_not_heard_timeout_from_its_restart(two_participants):
    (node, _), execs = two_participants
    gate = AllowanceGate(node, ["fusion"], timeout_s=0.3, first_timeout_s=0.3)
    time.sleep(0.4)                  # the time source waited this long for its subscribers
    gate.restart()
    assert gate.limit_s() == 0.0 and not gate.dropped               # still held for the node
    time.sleep(0.4)
    assert gate.limit_s() == float("inf") and gate.dropped == {"fusion"}     # never heard: no longer waited for


@pytest.mark.graph
def test_a_node_not_heard_yet_is_waited_for_longer_than_a_silent_one(two_participants):
    """A node that has not sent its first allowance is still starting: the
    gate holds the clock for it ``first_timeout_s`` (not the silent-node
    ``timeout_s``), and does not count it as heard until it speaks."""
    (node, _), execs = two_participants
    gate = AllowanceGate(node, ["fusion"], timeout_s=0.2, first_timeout_s=0.8)
    gate.restart()
    time.sleep(0.4)
    assert gate.limit_s() == 0.0 and not gate.dropped and not gate.all_heard()
    time.sleep(0.6)
    assert gate.limit_s() == float("inf") and gate.dropped == {"fusion"} and gate.all_heard()
    assert AllowanceGate(node, ["x"], timeout_s=5.0, first_timeout_s=1.0).first_timeout_s == 5.0


def test_drain_pace_follows_the_clock_of_the_last_pass_that_emptied_every_queue():
    pace = DrainPace(lead_s=0.5)
    assert pace.allowance_s(3.0) == 3.5                 # nothing received yet: nothing queued
    pace.drained(10.0)
    assert pace.allowance_s(12.0) == 10.5               # a backlog since 10 s holds the clock there
    pace.drained(9.0)                                   # an older pass (clock read earlier) never moves it back
    assert pace.allowance_s(12.0) == 10.5
    pace.drained(12.0)
    assert pace.allowance_s(12.0) == 12.5


@pytest.mark.graph
def test_input_drain_takes_every_queue_whatever_its_rate(two_participants):
    """Issue 33: the executor takes one message per ready subscription per
    wait, so a node short of CPU took its 8x stream at the rate of its slow
    one and the fast queue (KEEP_LAST) overflowed while the slow one looked
    current. One drain pass takes both queues whole; a pass cut short by
    max_per_topic does not count as drained."""
    (sub_node, pub_node), execs = two_participants
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    got = {"fast": [], "slow": []}
    subs = [sub_node.create_subscription(Imu, f"test/{k}", lambda m, k=k: got[k].append(m.header.stamp.sec), qos)
            for k in got]
    pubs = {k: pub_node.create_publisher(Imu, f"test/{k}", qos) for k in got}
    assert _spin_until(execs, lambda: all(p.get_subscription_count() == 1 for p in pubs.values())
                       and all(s.get_publisher_count() == 1 for s in subs), 30.0)
    time.sleep(0.5)                                     # discovery is one-sided: let the readers match too
    drain = InputDrain(sub_node, lambda: subs, lead_s=0.5, max_per_topic=300)
    for i in range(400):                                # 400 fast, 50 slow: the IMU and its load
        m = Imu()
        m.header.stamp.sec = i
        pubs["fast"].publish(m)
        if i % 8 == 0:
            pubs["slow"].publish(m)
    for p in pubs.values():
        assert p.wait_for_all_acked(rclpy.duration.Duration(seconds=10.0))
    t_before = drain.now_s()
    assert drain.drain() == 350                         # 300 fast (cut short), all 50 slow
    assert drain.cut_short == 1 and drain.pace.clock_s is None    # not drained: proves nothing
    assert drain.drain() == 100 and drain.pace.clock_s >= t_before
    assert got["fast"] == list(range(400)) and got["slow"] == list(range(0, 400, 8))   # all, in order
    assert drain.drain() == 0 and drain.taken == 450
    assert drain.allowance_s() == pytest.approx(drain.pace.clock_s + 0.5)


@pytest.mark.graph
def test_inputs_idle_sees_a_backlog_on_any_input_without_taking_it(two_participants):
    """The fusion node's rule (it keeps its executor's order): the clock
    stays at the last moment every input queue was empty, + lead."""
    (sub_node, pub_node), execs = two_participants
    got = {"fast": 0, "slow": 0}

    def count(k):
        got[k] += 1
    subs = [sub_node.create_subscription(Imu, f"test/{k}", lambda m, k=k: count(k), RELIABLE) for k in got]
    pub = pub_node.create_publisher(Imu, "test/fast", RELIABLE)
    clock = [5.0]
    idle = InputsIdle(sub_node, lambda: subs, lead_s=0.5, clock_s=lambda: clock[0])
    assert idle.check() and idle.allowance_s() == 5.5          # nothing queued
    assert _spin_until(execs, lambda: pub.get_subscription_count() == 1 and subs[0].get_publisher_count() == 1,
                       30.0)
    time.sleep(0.5)
    pub.publish(Imu())
    assert pub.wait_for_all_acked(rclpy.duration.Duration(seconds=10.0))
    clock[0] = 7.0
    deadline = time.monotonic() + 10.0
    while idle.check() and time.monotonic() < deadline:        # until the message is in the queue
        time.sleep(0.01)
    assert not idle.check() and got["fast"] == 0               # a backlog: seen, not taken
    assert idle.pace.clock_s <= 7.0                            # (the last pass that found it empty)
    clock[0] = 9.0
    assert idle.allowance_s() < 9.0                            # held while the queue is not empty
    assert _spin_until(execs, lambda: got["fast"] == 1, 10.0)  # the executor takes it, in its own order
    assert idle.check() and idle.allowance_s() == 9.5
