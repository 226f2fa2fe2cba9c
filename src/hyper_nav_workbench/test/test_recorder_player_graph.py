"""Recorder and player as real processes over DDS: record 200 Imu, replay them.
A transient-local topic published before the recorder starts is recorded
with its offered QoS and replayed transient local, so a subscriber that joins
late still gets it (as with rosbag2).

The test runs its own rclpy context on a random ROS domain restricted to
localhost, so graphs of other runs on the same machine stay out of the bag.
"""

import os
import random
import signal
import subprocess
import time
from pathlib import Path

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu
from std_msgs.msg import String

from hyper_nav_workbench.core import bag

N = 200
TOPIC = "/imu/data_raw"
QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def executable(name):
    try:
        from ament_index_python.packages import get_package_prefix

        prefix = Path(get_package_prefix("hyper_nav_workbench"))
    except Exception:
        prefix = Path(__file__).resolve().parents[3] / "install" / "hyper_nav_workbench"
    exe = prefix / "lib" / "hyper_nav_workbench" / name
    if not exe.is_file():
        pytest.skip(f"{exe} not built (run tools/setup.sh)")
    return str(exe)


def make_imu(i):
    msg = Imu()
    msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = i, 1000 * i, "imu"
    msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = 1e-3 * i, -float(i), 0.5
    msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = float(i), 2.0 * i, 9.81
    msg.orientation.w = 1.0
    return msg


def imu_values(msg):
    """Comparable tuple of an Imu (rclpy or rosbags object)."""
    s, w, a = msg.header.stamp, msg.angular_velocity, msg.linear_acceleration
    return (s.sec, s.nanosec, msg.header.frame_id, w.x, w.y, w.z, a.x, a.y, a.z, msg.orientation.w)


def spin_until(executor, done, timeout_s, what):
    deadline = time.monotonic() + timeout_s
    while not done():
        assert time.monotonic() < deadline, f"timed out after {timeout_s} s waiting for {what}"
        executor.spin_once(timeout_sec=0.05)


def finish(proc, timeout_s=30):
    try:
        out, _ = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
        pytest.fail(f"process did not exit within {timeout_s} s:\n{out}")
    return proc.returncode, out


@pytest.fixture
def ros(monkeypatch):
    """(context, node, executor) on an isolated, localhost-only domain; env set for children."""
    domain = random.randint(1, 101)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    ctx = rclpy.context.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node("bag_graph_test", context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    yield ctx, node, executor
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=ctx)


@pytest.mark.graph
def test_record_then_replay(ros, tmp_path):
    ctx, node, executor = ros
    bag_dir = tmp_path / "bag"
    sent = [make_imu(i) for i in range(N)]

    # --- record -------------------------------------------------------------
    recorded = {}
    node.create_subscription(
        DiagnosticArray, "/recorder/counts",
        lambda m: recorded.update({kv.key: int(kv.value) for s in m.status for kv in s.values}), 10)
    pub = node.create_publisher(Imu, TOPIC, QOS)
    latched_pub = node.create_publisher(String, "/latched", LATCHED)
    latched_pub.publish(String(data="published before the recorder started"))
    recorder = subprocess.Popen(
        [executable("recorder"), "--ros-args", "-p", f"output:={bag_dir}"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=os.environ.copy())
    try:
        spin_until(executor, lambda: pub.get_subscription_count() >= 1, 30, "the recorder to subscribe")
        for msg in sent:
            pub.publish(msg)
            time.sleep(0.01)  # ~100 msg/s: the replay lasts ~2 s, time for a late subscriber to join
        spin_until(executor, lambda: recorded.get(TOPIC, 0) >= N and recorded.get("/latched", 0) >= 1, 30,
                   f"the recorder to count {N} messages and the latched one")
    finally:
        recorder.send_signal(signal.SIGINT)
        code, out = finish(recorder)
    assert code == 0, out
    assert f"{TOPIC}: {N}" in out, out

    reader = bag.read_bag(bag_dir)
    records = [r for r in reader if r.topic == TOPIC]
    assert not reader.truncated and reader.error is None
    assert (bag_dir / "metadata.yaml").is_file()
    assert reader.counts[TOPIC] == N
    assert not {"/rosout", "/parameter_events"} & set(reader.topics)
    assert {r.msgtype for r in records} == {"sensor_msgs/msg/Imu"}
    assert [imu_values(bag.deserialize(r.raw, r.msgtype)) for r in records] == [imu_values(m) for m in sent]
    times = [r.t_ns for r in records]
    assert times == sorted(times)
    all_times = [r.t_ns for r in bag.read_bag(bag_dir)]
    assert reader.counts["/latched"] == 1
    assert [q["durability"] for q in reader.qos["/latched"]] == ["transient_local"]
    assert [(q["durability"], q["reliability"]) for q in reader.qos[TOPIC]] == [("volatile", "reliable")]

    # --- replay -------------------------------------------------------------
    node.destroy_publisher(pub)
    node.destroy_publisher(latched_pub)
    received, clocks, late = [], [], []
    node.create_subscription(Imu, TOPIC, received.append, QOS)
    node.create_subscription(Clock, "/clock", clocks.append, QOS)
    player = subprocess.Popen(
        [executable("player"), "--ros-args", "-p", f"bag:={bag_dir}", "-p", f"wait_topics:=['{TOPIC}']",
         "-p", "wait_counts:=[1]",
         "-p", f"topics:=['{TOPIC}', '/latched']"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=os.environ.copy())
    try:
        spin_until(executor, lambda: len(received) >= 1, 60, "the first replayed message")
        # a subscriber joining after /latched was replayed still gets it (transient local kept)
        node.create_subscription(String, "/latched", late.append, LATCHED)
        spin_until(executor, lambda: len(received) >= N and late, 60, f"{N} replayed messages and /latched")
    finally:
        code, out = finish(player)
    assert code == 0, out
    assert f"replayed {N + 1} messages (truncated: no)" in out, out
    assert [m.data for m in late] == ["published before the recorder started"]
    assert [imu_values(m) for m in received] == [imu_values(m) for m in sent]
    assert clocks, "no /clock published"
    clock_ns = [c.clock.sec * 10**9 + c.clock.nanosec for c in clocks]
    assert set(clock_ns) <= set(all_times)
    assert clock_ns == sorted(clock_ns)
