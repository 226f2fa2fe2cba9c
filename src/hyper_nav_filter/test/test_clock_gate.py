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

from hyper_nav_filter.clock_gate import TOPIC, AllowanceGate, ClockAllowance, InputsReady
from hyper_nav_sim.testing import isolated_domain_id

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
