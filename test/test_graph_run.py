"""The node graph as separate processes over DDS: topics, rates, delivery,
live vs offline equality, accuracy. Real rclpy, real Fast DDS, real MCAP."""
import numpy as np
import pytest
from ament_index_python.packages import get_package_prefix

from hyper_nav_filter.offline import run_offline
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.core.scoring import errors, states_from_msgs, summarize
from hyper_nav_workbench.report import delivery_check

pytestmark = pytest.mark.graph

EXPECTED = {  # topic: (type, nominal rate Hz over the 30 s flight)
    "/imu/data_raw": ("sensor_msgs/msg/Imu", 50.0),
    "/gnss/fix": ("sensor_msgs/msg/NavSatFix", 10.0),
    "/gnss/vel": ("geometry_msgs/msg/TwistWithCovarianceStamped", 10.0),
    "/imu/mag": ("sensor_msgs/msg/MagneticField", 10.0),
    "/truth/state": ("hyper_nav_msgs/msg/NavState", 50.0),
    "/nav/state": ("hyper_nav_msgs/msg/NavState", 50.0),
    "/nav/odom": ("nav_msgs/msg/Odometry", 50.0),
    "/nav/fix": ("sensor_msgs/msg/NavSatFix", 50.0),
    "/clock": ("rosgraph_msgs/msg/Clock", 50.0),
    "/diagnostics": ("diagnostic_msgs/msg/DiagnosticArray", None),
}


def test_every_topic_with_type_and_nominal_rate(recorded_run):
    reader = read_bag(recorded_run["bag"])
    msgs = {}
    for rec in reader:
        msgs.setdefault(rec.topic, []).append(rec)
    for topic, (msgtype, rate) in EXPECTED.items():
        assert topic in reader.topics, f"{topic} missing from the bag"
        assert reader.topics[topic] == msgtype
        if rate is None or topic == "/clock":
            continue
        stamps = np.array([deserialize(r.raw, msgtype).header.stamp.sec +
                           deserialize(r.raw, msgtype).header.stamp.nanosec * 1e-9 for r in msgs[topic]])
        period = np.median(np.diff(stamps))
        assert period == pytest.approx(1.0 / rate, rel=1e-6), topic
    # 30 s of data at the nominal rates (nav outputs lag by output_delay_s = 0.3 s)
    c = reader.counts
    assert c["/imu/data_raw"] == 1500 and c["/gnss/fix"] == 300 and c["/imu/mag"] == 300
    assert c["/truth/state"] == 1501
    assert c["/nav/state"] == 1500               # every IMU epoch, the last output_delay_s released at shutdown


def test_nothing_lost_between_publishers_and_subscribers(recorded_run):
    delivery = delivery_check(recorded_run)
    for topic in ("imu/data_raw", "gnss/fix", "gnss/vel", "imu/mag", "truth/state", "nav/state", "nav/odom", "clock"):
        assert topic in delivery, f"no publisher count for {topic}"
        assert delivery[topic]["published"] == delivery[topic]["recorded"] > 0, (topic, delivery[topic])
    fusion = recorded_run["diagnostics"]["hyper_nav_filter: fusion"]
    for topic in ("imu/data_raw", "gnss/fix", "gnss/vel"):          # every declared input received and used
        assert int(fusion[f"received {topic}"]) == int(fusion[f"processed {topic}"]) == \
            delivery[topic]["published"], (topic, fusion)
    assert fusion["mode"] == "loosely coupled" and fusion["mode_sources"] == "gnss_pos,gnss_vel"
    assert int(fusion["heartbeat"]) >= 1
    assert int(fusion.get("rejected_imu_nan", 0)) == 0


def test_live_fusion_equals_offline_core_on_the_bag(recorded_run):
    """The replay of the bag gives the live node's solutions bit for bit,
    whatever order the recorder received the messages in: the core is fed in
    stamp order, and every input the node received behind the IMU (reported
    on nav/late_inputs) where the node received it (replay_order)."""
    sc = recorded_run["scenario"]
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(recorded_run["bag"])
               if r.topic in ("/imu/data_raw", "/gnss/fix", "/gnss/vel", "/nav/late_inputs")]
    sols, eng = run_offline(records, sc.filter_config(), sc.filter_initial_state(), sc.filter_sources(), final=True)
    assert eng.replay.missing == ()                      # every late input the node reported is in the bag
    live = recorded_run["nav"]
    assert len(live) == len(sols) == 1500
    for msg, sol in zip(live, sols):
        assert msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9 == pytest.approx(sol.t_s, abs=1e-9)
        assert (msg.lat_rad, msg.lon_rad, msg.alt_m) == (sol.state.lat_rad, sol.state.lon_rad, sol.state.alt_m)
        assert np.array_equal(np.asarray(msg.vel_enu_mps), sol.state.vel_enu_mps)
        assert np.array_equal(np.asarray(msg.covariance).reshape(15, 15), sol.P)
    fusion = recorded_run["diagnostics"]["hyper_nav_filter: fusion"]
    assert int(fusion["published nav/late_inputs"]) == eng.replay.placed


def test_short_run_accuracy_against_truth(recorded_run):
    err = errors(states_from_msgs(recorded_run["nav"]), states_from_msgs(recorded_run["truth"]))
    s = summarize(err, 10.0)
    assert s["pos_enu_m"]["rms_3d"] < 5.0
    assert s["vel_enu_mps"]["rms_3d"] < 0.1
    assert s["att_enu_deg"]["rms_3d"] < 0.05


def test_messages_carry_real_covariances_and_frames(recorded_run):
    reader = read_bag(recorded_run["bag"])
    first = {}
    for r in reader:
        first.setdefault(r.topic, deserialize(r.raw, r.msgtype))
    imu = first["/imu/data_raw"]
    assert imu.orientation_covariance[0] == -1.0 and imu.header.frame_id == "imu_link"
    assert all(imu.angular_velocity_covariance[i] > 0 for i in (0, 4, 8))
    vel = first["/gnss/vel"]
    assert vel.header.frame_id == "enu" and vel.twist.covariance[0] == pytest.approx(0.01)
    fix = first["/gnss/fix"]
    assert fix.position_covariance[0] == pytest.approx(25.0) and fix.position_covariance_type in (2, 3)
    odom = first["/nav/odom"]
    assert odom.header.frame_id == "map" and odom.child_frame_id == "base_link"
    assert min(odom.pose.covariance[i * 7] for i in range(6)) > 0
    assert min(first["/nav/fix"].position_covariance[i * 4] for i in range(3)) > 0
    assert first["/imu/mag"].magnetic_field_covariance[0] > 0


def test_executables_sit_where_ros2_run_finds_them():
    expected = {"hyper_nav_sim": ["truth_node", "imu_node", "gnss_node", "mag_node"],
                "hyper_nav_workbench": ["recorder", "player", "run_graph"],
                "hyper_nav_filter": ["fusion_node"]}
    import os
    for pkg, exes in expected.items():
        prefix = get_package_prefix(pkg)
        for exe in exes:
            path = os.path.join(prefix, "lib", pkg, exe)
            assert os.access(path, os.X_OK), path
