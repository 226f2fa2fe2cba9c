"""The recorder never loses silently (issue 33): beyond what it can take,
its subscription queue (KEEP_LAST) overflows, and it counts every message
that never reached the bag from the writer's sequence numbers: ``lost
<topic>`` in its last status (ERROR) and on its console, equal to
published - recorded. Forced here: the recorder is frozen (SIGSTOP) while
2,980 messages are published into a queue of 20, then resumed, between
messages that reach it."""
import os
import re
import signal
import subprocess
import time

import pytest
import rclpy
import yaml
from ament_index_python.packages import get_package_prefix
from rclpy.duration import Duration
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu

from hyper_nav_workbench.core.bag import read_bag

pytestmark = pytest.mark.graph
N = 3000


def test_a_recorder_that_cannot_keep_up_counts_what_it_lost(tmp_path):
    domain = int(os.environ["ROS_DOMAIN_ID"])          # this pytest process's own (conftest.py)
    bag = tmp_path / "bag"
    params = tmp_path / "recorder.yaml"
    params.write_text(yaml.safe_dump({"/**": {"ros__parameters": {
        "output": str(bag), "topics": ["/test/fast", "/test/other"], "qos_depth": 20}}}))
    exe = os.path.join(get_package_prefix("hyper_nav_workbench"), "lib", "hyper_nav_workbench", "recorder")
    log = tmp_path / "recorder.log"
    rec = subprocess.Popen([exe, "--ros-args", "--params-file", str(params)], stdout=log.open("w"),
                           stderr=subprocess.STDOUT, env=dict(os.environ, ROS_DOMAIN_ID=str(domain)))
    ctx = rclpy.context.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node("burst", context=ctx)
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=N, reliability=ReliabilityPolicy.RELIABLE)
    fast, other = (node.create_publisher(Imu, t, qos) for t in ("/test/fast", "/test/other"))
    try:
        deadline = time.monotonic() + 60.0
        while fast.get_subscription_count() < 1 or other.get_subscription_count() < 1:
            assert time.monotonic() < deadline and rec.poll() is None, log.read_text()
            time.sleep(0.05)
        time.sleep(1.0)                             # one-sided matching: let the recorder's readers match too
        other.publish(Imu())                        # a topic that keeps up: nothing lost there
        assert other.wait_for_all_acked(Duration(seconds=10.0))

        def send(first, n):
            for i in range(first, first + n):
                m = Imu()
                m.header.stamp.sec = i
                fast.publish(m)
        send(0, 10)                                 # the stream runs: the recorder has its sequence
        assert fast.wait_for_all_acked(Duration(seconds=10.0))
        os.kill(rec.pid, signal.SIGSTOP)
        try:
            send(10, N - 20)                        # the burst, into a stopped recorder's queue of 20
            time.sleep(1.0)
        finally:
            os.kill(rec.pid, signal.SIGCONT)
        fast.wait_for_all_acked(Duration(seconds=20.0))
        time.sleep(1.0)
        send(N - 10, 10)                            # the stream goes on
        fast.wait_for_all_acked(Duration(seconds=10.0))
        time.sleep(1.0)
    finally:
        rec.send_signal(signal.SIGINT)
        rec.wait(timeout=60)
        node.destroy_node()
        ctx.try_shutdown()
    recorded = {}
    for r in read_bag(bag):
        recorded[r.topic] = recorded.get(r.topic, 0) + 1
    text = log.read_text()
    lost = re.search(r"/test/fast: (\d+) \((\d+) LOST\)", text)
    assert lost, text
    assert int(lost.group(1)) == recorded["/test/fast"] < N            # the queue overflowed ...
    # ... and every lost message is counted (a loss inside the stream; one before a topic's first recorded
    # message or after its last is seen by the report's check against the publishers' counts only)
    assert int(lost.group(2)) == N - recorded["/test/fast"] > 0
    assert recorded["/test/other"] == 1 and "/test/other: 1\n" in text  # the other topic lost nothing
    assert "lost before the bag" in text
