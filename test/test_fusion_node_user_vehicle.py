"""The fusion node as a user starts it on their own vehicle (issue 35):
``ros2 run hyper_nav_filter fusion_node`` with no parameters starts and waits
for data; with a shipped parameter file (``--ros-args --params-file``) and
plain rclpy publishers of sensor_msgs/Imu, NavSatFix and
TwistWithCovarianceStamped (wall-clock stamps, as a vehicle's), it publishes
one current-time state per IMU sample, stamped with it, on ``nav/odom``,
``nav/state`` (with covariance) and ``/tf``, and the delayed record on
``nav/delayed/state``; a wrong parameter is one line naming it. Asserts on
what was received, never on when."""
from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import threading
import time

import numpy as np
import pytest
import rclpy
from ament_index_python.packages import get_package_share_directory
from geometry_msgs.msg import TwistWithCovarianceStamped
from hyper_nav_msgs.msg import NavState
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu, NavSatFix
from tf2_msgs.msg import TFMessage

from hyper_nav_gnss import earth
from hyper_nav_filter.ros_util import publisher_qos
from hyper_nav_workbench.testing import TopicCollector, isolated_domain_id

pytestmark = pytest.mark.graph
ROS2RUN = str(pathlib.Path(__file__).resolve().parents[1] / "tools" / "ros2run")
PARAMS = pathlib.Path(get_package_share_directory("hyper_nav_filter")) / "params"
LAT_DEG, LON_DEG, ALT_M = 30.0, 120.0, 50.0
IMU_HZ, N_IMU = 100.0, 600


def _start(args, domain):
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain)}
    return subprocess.Popen([ROS2RUN, "hyper_nav_filter", "fusion_node", *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)


def _stop(proc, timeout=30.0) -> str:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
    return out


def test_no_parameters_starts_and_waits_for_data():
    proc = _start([], isolated_domain_id())
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)   # until it exits
    reader.start()
    try:
        deadline = time.monotonic() + 120.0                 # a loaded machine: the start may take a while
        while time.monotonic() < deadline and proc.poll() is None and \
                not any("outputs matched" in ln for ln in list(lines)):
            time.sleep(0.5)
        time.sleep(2.0)
        alive = proc.poll() is None                         # started, waiting for data, not dead
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(timeout=30.0)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
        reader.join(timeout=10.0)
    out = "".join(lines)
    assert alive, out
    assert "Traceback" not in out, out
    assert "sources: imu (imu) <- imu/data_raw, gnss_fix (gnss_fix) <- gnss/fix, gnss_vel (gnss_vel) <- gnss/vel" \
        in out, out


@pytest.mark.parametrize("args, name", [
    (["-p", "filter.output_delay_s:=-1.0"], "filter.output_delay_s"),
    (["-p", "sources.imu.type:=imuu"], "sources.imu.type"),
    (["-p", "sources.gnss_fix.delay_s:=2.0"], "sources.gnss_fix.delay_s"),
    (["-p", "executor:=event"], "executor"),
    (["-p", "realtime.priority:=120"], "realtime.priority"),
    (["-p", "qos.depth:=0"], "qos.depth"),
    (["-p", "qos.depth:=many"], "qos.depth"),
])
def test_a_wrong_parameter_is_one_line_naming_it(args, name):
    proc = _start(["--ros-args", "--params-file", str(PARAMS / "loosely_coupled.yaml"), *args], isolated_domain_id())
    try:
        proc.wait(timeout=60.0)
    finally:
        out = _stop(proc)
    assert proc.returncode == 2, out
    assert "Traceback" not in out, out
    lines = [ln for ln in out.splitlines() if "error" in ln]
    assert len(lines) == 1 and name in lines[0], out


REALTIME = ["-p", "realtime.priority:=10", "-p", "realtime.lock_memory:=true", "-p", "realtime.cpu_dma_latency_us:=0"]


@pytest.mark.parametrize("executor, extra", [("single", []), ("events", []), ("events", REALTIME)],
                         ids=["single", "events", "events-realtime"])
def test_params_file_node_gives_one_current_time_state_per_imu_sample(executor, extra):
    """In either executor (``-p executor:=events``: rclpy's EventsExecutor),
    and with a rig's real-time settings (``realtime.*``: SCHED_FIFO for every
    thread of the node, memory locked, the PM QoS request held)."""
    domain = isolated_domain_id()
    t0 = time.time()
    # (the file's IMU QoS is sensor_data, best effort, as drivers publish; reliable here: nothing may be lost)
    proc = _start(["--ros-args", "--params-file", str(PARAMS / "loosely_coupled.yaml"), "-p", "sources.imu.qos:=reliable",
                   "-p", f"init.lat_deg:={LAT_DEG}", "-p", f"init.lon_deg:={LON_DEG}", "-p", f"init.alt_m:={ALT_M}",
                   "-p", f"executor:={executor}", *extra],
                  domain)
    topics = {"nav/odom": Odometry, "nav/state": NavState, "/tf": TFMessage, "nav/delayed/state": NavState}
    try:
        with TopicCollector(topics, domain_id=domain) as c:
            ctx = rclpy.context.Context()
            rclpy.init(context=ctx, domain_id=domain)
            node = rclpy.create_node("user_sensors", context=ctx)
            qos = publisher_qos(2000)
            pub_imu = node.create_publisher(Imu, "imu/data_raw", qos)
            pub_fix = node.create_publisher(NavSatFix, "gnss/fix", qos)
            pub_vel = node.create_publisher(TwistWithCovarianceStamped, "gnss/vel", qos)
            try:
                deadline = time.monotonic() + 90.0
                while time.monotonic() < deadline and not (pub_imu.get_subscription_count() and
                                                           pub_fix.get_subscription_count() and
                                                           c.node.count_publishers("nav/odom")):
                    time.sleep(0.2)
                assert pub_imu.get_subscription_count(), _stop(proc)
                if extra and os.geteuid() == 0:       # privileged here: applied to every thread of the node
                    tasks = pathlib.Path(f"/proc/{proc.pid}/task").iterdir()
                    assert {os.sched_getscheduler(int(t.name)) for t in tasks} == {os.SCHED_FIFO}
                time.sleep(1.0)
                g = -earth.gravity_n(np.deg2rad(LAT_DEG), ALT_M)[2]
                w_ie = earth.omega_ie_n(np.deg2rad(LAT_DEG))
                stamps = []
                for k in range(N_IMU):                          # a vehicle at rest, body FLU = ENU
                    t = t0 + 1.0 + k / IMU_HZ
                    sec, ns = int(t), int(round((t - int(t)) * 1e9))
                    m = Imu()
                    m.header.stamp.sec, m.header.stamp.nanosec = sec, ns
                    m.header.frame_id = "imu_link"
                    m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = (float(x) for x in w_ie)
                    m.linear_acceleration.z = float(g)
                    pub_imu.publish(m)
                    stamps.append((sec, ns))
                    if k % 10 == 5:
                        f = NavSatFix()
                        f.header.stamp.sec, f.header.stamp.nanosec = sec, ns
                        f.status.status, f.status.service = 0, 1      # STATUS_FIX (Jazzy's default is UNKNOWN)
                        f.latitude, f.longitude, f.altitude = LAT_DEG, LON_DEG, ALT_M
                        f.position_covariance = [4.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 9.0]
                        f.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN
                        pub_fix.publish(f)
                        v = TwistWithCovarianceStamped()
                        v.header.stamp.sec, v.header.stamp.nanosec = sec, ns
                        cov = np.zeros((6, 6))
                        cov[:3, :3] = np.eye(3) * 0.01
                        v.twist.covariance = cov.ravel().tolist()
                        pub_vel.publish(v)
                    time.sleep(1.0 / IMU_HZ)
                assert c.wait_for(lambda m: len(m["nav/odom"]) >= N_IMU and len(m["nav/state"]) >= N_IMU
                                  and len(m["/tf"]) >= N_IMU, 90.0), \
                    ({t: len(v) for t, v in c.messages.items()}, _stop(proc))
                time.sleep(1.0)
                msgs = {t: list(v) for t, v in c.messages.items()}
            finally:
                node.destroy_node()
                rclpy.try_shutdown(context=ctx)
    finally:
        out = _stop(proc)
    assert "Traceback" not in out, out

    def key(stamp):
        return stamp.sec, stamp.nanosec
    # one current-time state per IMU sample, stamped with it, on each consumer topic
    for topic in ("nav/odom", "nav/state"):
        assert [key(m.header.stamp) for m in msgs[topic]] == stamps, topic
    assert [key(m.transforms[0].header.stamp) for m in msgs["/tf"]] == stamps
    assert all(m.transforms[0].header.frame_id == "map" and m.transforms[0].child_frame_id == "base_link"
               for m in msgs["/tf"])
    last = msgs["nav/state"][-1]
    P = np.asarray(last.covariance).reshape(last.state_dim, last.state_dim)
    assert last.state_dim == 15 and np.all(np.diag(P) > 0) and np.allclose(P, P.T)
    # at rest at the fixed point: the current-time state stays there (fixes 2 m / 3 m 1-sigma)
    err = earth.position_error_enu_m(last.lat_rad, last.lon_rad, last.alt_m, np.deg2rad(LAT_DEG),
                                     np.deg2rad(LON_DEG), ALT_M)
    assert np.linalg.norm(err) < 5.0, err
    assert np.linalg.norm(last.vel_enu_mps) < 0.5
    odom = msgs["nav/odom"][-1]
    assert np.linalg.norm([odom.pose.pose.position.x, odom.pose.pose.position.y, odom.pose.pose.position.z]) < 5.0
    # the delayed record: released behind, on the output grid, a subset of the IMU stamps
    # (its stamps from the engine's float seconds: 0.24 us resolution at a wall-clock epoch)
    delayed = np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in msgs["nav/delayed/state"]])
    imu_t = np.array([sec + ns * 1e-9 for sec, ns in stamps])
    assert len(delayed) > 0.5 * (N_IMU / IMU_HZ - 1.0) * 50
    assert np.all(np.min(np.abs(delayed[:, None] - imu_t[None, :]), axis=1) < 1e-6)
