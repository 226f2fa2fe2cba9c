"""Recorder and player as real processes over DDS: record 200 Imu, replay them.

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
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu

from hyper_nav_sim.core import bag

N = 200
TOPIC = "/imu/data_raw"
QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def executable(name):
    try:
        from ament_index_python.packages import get_package_prefix

        prefix = Path(get_package_prefix("hyper_nav_sim"))
    except Exception:
        prefix = Path(__file__).resolve().parents[3] / "install" / "hyper_nav_sim"
    exe = prefix / "lib" / "hyper_nav_sim" / name
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
    recorder = subprocess.Popen(
        [executable("recorder"), "--ros-args", "-p", f"output:={bag_dir}"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=os.environ.copy())
    try:
        spin_until(executor, lambda: pub.get_subscription_count() >= 1, 30, "the recorder to subscribe")
        for msg in sent:
            pub.publish(msg)
            time.sleep(0.002)  # ~500 msg/s
        spin_until(executor, lambda: recorded.get(TOPIC, 0) >= N, 30, f"the recorder to count {N} messages")
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

    # --- replay -------------------------------------------------------------
    node.destroy_publisher(pub)
    received, clocks = [], []
    node.create_subscription(Imu, TOPIC, received.append, QOS)
    node.create_subscription(Clock, "/clock", clocks.append, QOS)
    player = subprocess.Popen(
        [executable("player"), "--ros-args", "-p", f"bag:={bag_dir}", "-p", "wait_for_subscribers:=1",
         "-p", f"topics:=['{TOPIC}']"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=os.environ.copy())
    try:
        spin_until(executor, lambda: len(received) >= N, 60, f"{N} replayed messages")
    finally:
        code, out = finish(player)
    assert code == 0, out
    assert f"replayed {N} messages (truncated: no)" in out, out
    assert [imu_values(m) for m in received] == [imu_values(m) for m in sent]
    assert clocks, "no /clock published"
    clock_ns = [c.clock.sec * 10**9 + c.clock.nanosec for c in clocks]
    assert set(clock_ns) <= set(times)
    assert clock_ns == sorted(clock_ns)
