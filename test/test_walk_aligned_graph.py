"""The walk_0827 recording as a user brings it (real_data/walk_imu.yaml: IMU
mounting, no initial state, MEMS error model): imported with the alignment
on the data, the first 15 s after the alignment epoch played by the player
at real time, and the whole walk played at 50x held back by the fusion
node's allowance (slow), into a live fusion node give the same solutions as
the offline core over the same bag, bit for bit (issue 21: live == offline
on the real bag).
Issue 22: the collector matches the node's nav/state before the player
starts, the player waits for the node's allowance, which the node sends
only once its subscriptions have matched the player, and the player's
not-heard timeout counts from its start (before that, loaded runs lost
the first 0.2 to 5 s of solutions)."""
import numpy as np
import pytest
import yaml
from tf2_msgs.msg import TFMessage

from hyper_nav_workbench import import_data
from hyper_nav_repro.walk import reproduce as repro_walk
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.core.importer import columns, gnss_raw
from hyper_nav_sim.core.scenario import find_scenario, load_scenario
from hyper_nav_workbench.spp import default_data_dir
from hyper_nav_workbench.testing import play_into_fusion

INPUTS = ["/imu/data_raw", "/gnss/raw", "/gnss/ephemeris"]
SEGMENTS = [pytest.param(15.0, 1.0, id="first_15s_real_time"),
            pytest.param(None, 50.0, id="whole_walk_as_fast_as_allowed", marks=pytest.mark.slow)]


@pytest.mark.graph
@pytest.mark.parametrize("segment_s, rate", SEGMENTS)
@pytest.mark.skipif(not (default_data_dir() / "walk_0827" / "imu_1730_sf.csv").exists(),
                    reason="shared walk_0827 data not found")
def test_aligned_walk_replays_into_live_fusion_node_as_offline(tmp_path, segment_s, rate):
    imported = import_data.load_import(repro_walk.walk_yaml())
    t_al = imported["alignment"].t_s
    if segment_s is not None:
        imported["imu"] = columns.window(imported["imu"], None, t_al + segment_s)
        imported["gnss_raw"] = gnss_raw.window(imported["gnss_raw"], t_al - 0.5, t_al + segment_s)
    bag = tmp_path / "bag"
    import_data.write(imported, bag)
    filt = imported["setup"]["filter"]
    from hyper_nav_filter.core.config import FilterConfig
    # a scenario takes declared names only: the config with its unit aliases resolved
    filt["config"] = {**FilterConfig.from_dict(filt["config"]).as_dict(), "output_rate_hz": 10.0}
    filt["initial_state"].setdefault("accel_bias_ug", [0.0, 0.0, 0.0])       # written out: nothing is drawn
    sc_file = tmp_path / "walk_aligned.yaml"
    sc_file.write_text(yaml.safe_dump({"extends": str(find_scenario("default")),
                                       "name": "walk_aligned", "filter": filt,
                                       "imu": {"mounting_b_xyzw": list(imported["imu"].mounting_b_xyzw)}}))
    sc = load_scenario(str(sc_file))
    recs = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(bag)]
    from hyper_nav_filter.offline import run_offline
    sols, eng = run_offline(recs, sc.filter_config(), sc.filter_initial_state(), sc.filter_sources())
    assert eng.kf.stats["pseudorange"][0] > 500 and len(sols) >= 100
    also = {"/tf_static": TFMessage}
    logs = {}
    live = play_into_fusion(sc_file, bag, INPUTS, len(sols), rate=rate, also=also, latched=("/tf_static",),
                            logs=logs)
    # the mounting the importer applied, on /tf_static: base_link -> imu_link rotated by it
    (imu_tf,) = [t for m in also["/tf_static"] for t in m.transforms if t.child_frame_id == "imu_link"]
    r = imu_tf.transform.rotation
    q_expected = np.asarray(imported["imu"].mounting_b_xyzw)
    assert abs(np.dot([r.x, r.y, r.z, r.w], q_expected)) == pytest.approx(1.0, abs=1e-9)
    assert abs(q_expected[3]) < 0.99                                                  # a real rotation (180/0/-90)
    for msg, sol in zip(live, sols):
        t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        assert t == pytest.approx(sol.t_s, abs=1e-6), (t, sol.t_s, logs)
        assert msg.lat_rad == sol.state.lat_rad and msg.lon_rad == sol.state.lon_rad       # bit for bit
        assert msg.alt_m == sol.state.alt_m
        assert np.array_equal(np.asarray(msg.vel_enu_mps), sol.state.vel_enu_mps)
    print(f"\nlive == offline (bit for bit) over {len(sols)} solutions; pseudorange updates {eng.kf.stats['pseudorange']}")
