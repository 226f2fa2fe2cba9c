"""ros_util.run_node: a node signalled to stop never stays behind, even when
one of its callbacks never returns (the watchdog armed by the signal ends it
by SIGALRM after exit_grace_s; a node whose stop completes exits normally)."""
import os
import signal
import subprocess
import sys
import time

import pytest

NODE = r"""
import sys, time
from rclpy.node import Node
from hyper_nav_filter.ros_util import run_node

class Stuck(Node):
    def __init__(self):
        super().__init__("stuck_" + sys.argv[1])
        self.create_timer(0.05, self.tick)
        print("ready", flush=True)

    def tick(self):
        if sys.argv[1] == "stuck":
            while True:           # a callback that never returns (a pure-Python busy loop)
                pass

run_node(Stuck, exit_grace_s=1.0 if sys.argv[1] == "stuck" else 30.0)   # free: room for a slow teardown on a busy machine
print("exited normally", flush=True)
"""


def _start(tmp_path, mode):
    script = tmp_path / "node.py"
    script.write_text(NODE)
    env = dict(os.environ, ROS_DOMAIN_ID=str(int(os.environ.get("ROS_DOMAIN_ID", "0")) or 1))
    p = subprocess.Popen([sys.executable, str(script), mode], stdout=subprocess.PIPE, text=True, env=env)
    assert p.stdout.readline().strip() == "ready"
    time.sleep(0.5)                                  # the timer has fired: "stuck" is in its loop
    return p


@pytest.mark.parametrize("mode,expect", [("stuck", -signal.SIGALRM), ("free", 0)])
def test_a_signalled_node_exits_within_its_grace(tmp_path, mode, expect):
    p = _start(tmp_path, mode)
    p.send_signal(signal.SIGTERM)
    try:
        code = p.wait(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()
        pytest.fail("the node stayed behind its SIGTERM")
    assert code == expect
    if mode == "free":
        assert "exited normally" in p.stdout.read()
