"""What ROS users expect around the filter, checked on the shared recorded
run (conftest: default flight, antenna and magnetometer off the IMU,
Foxglove view with a WebSocket client attached):
  * the replayed bag gives the REP-105 transform chain map -> base_link ->
    imu_link / gnss_antenna / magnetometer at every solution epoch, with the
    scenario's lever arms, and the antenna it places follows the true antenna;
  * the Foxglove live view served the run (map tracks, transforms, errors
    with the filter's sigmas equal to the report's errors);
  * the run plots' numbers (share inside +/-3 sigma, NEES) and PNGs."""
import numpy as np
import pytest

from hyper_nav_filter.conversions import stamp_to_s
from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import quat_xyzw_to_C
from hyper_nav_workbench import run_plots
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.core.scoring import errors, states_from_msgs

pytestmark = pytest.mark.graph


def _msgs(bag, topic):
    return [deserialize(r.raw, r.msgtype) for r in read_bag(bag, topics=[topic])]


def _quat(q):
    return quat_xyzw_to_C([q.x, q.y, q.z, q.w])


def test_transform_chain_at_every_solution_epoch_of_the_replayed_bag(recorded_run):
    bag, sc = recorded_run["bag"], recorded_run["scenario"]
    static = {t.child_frame_id: t for m in _msgs(bag, "/tf_static") for t in m.transforms}
    assert set(static) == {"imu_link", "gnss_antenna", "magnetometer"}
    assert all(t.header.frame_id == "base_link" for t in static.values())
    lever = {k: np.array([v.transform.translation.x, v.transform.translation.y, v.transform.translation.z])
             for k, v in static.items()}
    assert lever["gnss_antenna"] == pytest.approx(sc["gnss.antenna_lever_arm_b_m"])
    assert lever["magnetometer"] == pytest.approx(sc["magnetometer.lever_arm_b_m"])
    assert lever["imu_link"] == pytest.approx([0.0, 0.0, 0.0])
    tf = {}
    for m in _msgs(bag, "/tf"):
        for t in m.transforms:
            assert (t.header.frame_id, t.child_frame_id) == ("map", "base_link")
            tf[round(stamp_to_s(t.header.stamp) * 1e6)] = t
    nav, odom = recorded_run["nav"], _msgs(bag, "/nav/odom")
    assert len(tf) == len(nav) == len(odom) == 1500
    truth = {round(stamp_to_s(m.header.stamp) * 1e6): m for m in recorded_run["truth"]}
    o = odom[0].header
    origin = sc.trajectory().truth([0.0])
    lat0, lon0, alt0 = origin.lat_rad[0], origin.lon_rad[0], origin.alt_m[0]
    C_n_map0 = earth.C_n_e(lat0, lon0).T
    worst = 0.0
    for od in odom:
        key = round(stamp_to_s(od.header.stamp) * 1e6)
        t = tf[key].transform                                     # a transform at every solution epoch ...
        p = np.array([t.translation.x, t.translation.y, t.translation.z])
        assert p == pytest.approx([od.pose.pose.position.x, od.pose.pose.position.y, od.pose.pose.position.z],
                                  abs=1e-9)                       # ... the pose of nav/odom
        antenna = p + _quat(t.rotation) @ lever["gnss_antenna"]   # map -> base_link -> gnss_antenna
        tr = truth[key]
        C_true_map = C_n_map0 @ earth.C_n_e(tr.lat_rad, tr.lon_rad) @ _quat(tr.q_b_enu)
        true_antenna = earth.enu_offset_m(lat0, lon0, alt0, tr.lat_rad, tr.lon_rad, tr.alt_m) + \
            C_true_map @ lever["gnss_antenna"]
        if key >= 10e6:
            worst = max(worst, float(np.linalg.norm(antenna - true_antenna)))
    assert o.frame_id == "map"
    assert worst < 5.0, worst             # the filter's position accuracy (measured: ~1.5 m)


def test_foxglove_live_view_served_the_run(recorded_run):
    fox = recorded_run["foxglove"]
    assert fox.error is None, fox.error
    topics = {c["topic"]: (c["encoding"], c["schemaName"]) for c in fox.channels.values()}
    assert topics["/map/fused"] == ("protobuf", "foxglove.LocationFix")
    assert topics["/tf"] == ("protobuf", "foxglove.FrameTransforms")
    assert topics["/errors"][0] == "json"
    for t in ("/map/truth", "/map/fused", "/map/gnss", "/tf"):
        assert fox.count(t) > 50, (t, fox.count(t))
    assert fox.count("/vehicle") >= 1
    # /errors: the current-time stream (nav/state); /errors/delayed: the record (nav/delayed/state)
    for channel, stream in (("/errors", "current"), ("/errors/delayed", "nav")):
        recs = fox.messages[channel]
        assert len(recs) > 1000                   # 1500 solutions; the client joins while the graph starts
        err = errors(states_from_msgs(recorded_run[stream]), states_from_msgs(recorded_run["truth"]))
        by_t = {round(t * 1e6): i for i, t in enumerate(err["t"])}
        inside = []
        for r in recs:
            i = by_t[round(r["t_s"] * 1e6)]
            assert r["pos_err_enu_m"] == pytest.approx(err["pos_enu_m"][i], abs=1e-6)
            assert r["att_err_enu_deg"] == pytest.approx(err["att_enu_deg"][i], abs=1e-9)
            if r["t_s"] >= 5.0:
                inside.append(np.all(np.abs(r["pos_err_enu_m"]) <= 3 * np.asarray(r["pos_sigma_enu_m"])))
        assert np.mean(inside) > 0.95


def test_run_plots_show_errors_within_the_filters_bounds(recorded_run, tmp_path):
    bag = tmp_path / "copy"
    bag.mkdir()
    for f in recorded_run["bag"].iterdir():
        (bag / f.name).symlink_to(f)
    fig = run_plots.write(bag, recorded_run, recorded_run["scenario"])
    for png in ("errors.png", "consistency.png", "track.png"):
        assert (bag / png).stat().st_size > 20_000
    for key, share in fig["inside_3sigma"].items():
        assert min(share) > 0.9, (key, share)
    for b, v in fig["mean_nees"].items():
        assert 0.2 < v < 9.0, (b, v)                  # 3 expected; 9.3 = the 95 % bound of one epoch
    assert fig["n_nis"] > 250 and 1.0 < fig["median_nis"] < 5.0      # chi-square(3): median 2.37
    assert fig["gnss_outages_s"] == []


def test_gnss_outages_from_fix_times():
    t = np.r_[np.arange(0.0, 10.0, 0.1), np.arange(25.0, 30.0, 0.1)]
    assert run_plots.outages(t, 0.0, 40.0) == [(pytest.approx(9.9), 25.0), (pytest.approx(29.9), 40.0)]


def test_recorded_bag_as_a_foxglove_mcap_file(recorded_run, tmp_path):
    """foxglove_view --bag ... --out: the same view of a recorded run, in a file the app opens."""
    import json

    from mcap.reader import make_reader

    from hyper_nav_workbench.foxglove_view import main
    out = tmp_path / "view.mcap"
    assert main(["--bag", str(recorded_run["bag"]), "--out", str(out)]) == 0
    counts, first_err = {}, None
    with open(out, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/errors" and first_err is None:
                first_err = json.loads(message.data)
    assert counts["/errors"] == 1500 and counts["/tf"] == 1501          # every solution, plus /tf_static
    assert counts["/map/truth"] == 301 and counts["/map/fused"] == 300   # 10 Hz map points over 30 s (truth from t = 0)
    assert counts["/map/gnss"] == 300 and counts["/vehicle"] == 1
    assert first_err["pos_sigma_enu_m"][2] == pytest.approx(10.0, rel=1e-3)   # the initial sigma of the filter


def test_fusion_node_takes_initial_imu_errors_and_tf_parameters():
    """init.* (core.initial_state, declared once) reach the filter; tf.* the static frames."""
    import rclpy

    from hyper_nav_filter.core import units
    from hyper_nav_filter.nodes.fusion_node import FusionNode
    ctx = rclpy.context.Context()
    rclpy.init(context=ctx, args=["--ros-args", "-p", "sources:=[imu]", "-p", "sources.imu.type:=imu",
                                  "-p", "sources.imu.topic:=imu/data_raw", "-p", "init.lat_deg:=30.0", "-p", "init.alt_m:=1000.0",
                                  "-p", "init.gyro_bias_deg_per_hr:=[1.0, -2.0, 3.0]",
                                  "-p", "init.accel_bias_ug:=[100.0, 0.0, -50.0]",
                                  "-p", "filter.gate_probability:=1.0",
                                  "-p", "tf.magnetometer_position_b_m:=[0.5, 0.0, 0.0]"])
    try:
        node = FusionNode(context=ctx)
        kf = node.engine.kf
        assert kf.state.gyro_bias_b_radps == pytest.approx(units.deg_per_hr([1.0, -2.0, 3.0]))
        assert kf.state.accel_bias_b_mps2 == pytest.approx(units.ug([100.0, 0.0, -50.0]))
        assert kf.cfg.gate_probability == 1.0 and node.pub_tf_static is not None
        assert node.p["tf.magnetometer_position_b_m"] == (0.5, 0.0, 0.0)
        node.destroy_node()
    finally:
        ctx.try_shutdown()
