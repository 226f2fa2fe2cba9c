"""Real receiver data through the live graph: the first 10 s of the walk_0827
u-blox log and its MEMS IMU (../shared/real-data), imported by import_data's
``ubx`` preset, replayed by the player into a live fusion node (tightly
coupled, real-signal receiver model, one update per satellite), give the
same solutions as the offline core over the same bag."""
import importlib.util
import pathlib

import numpy as np
import pytest
import yaml

from hyper_nav_workbench import import_data
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_workbench.testing import play_into_fusion

REPO = pathlib.Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "hyper_nav_gnss_real_data", REPO / "src" / "hyper_nav_gnss" / "test" / "_real_data.py")
rd = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rd)

T_IMU0 = 1756402240.961
INPUTS = ["/imu/data_raw", "/gnss/raw", "/gnss/ephemeris"]
FILTER = {"config": {"state_blocks": ["att", "vel", "pos", "bg", "ba", "clk", "isb"],
                     "gyro_arw_deg_per_sqrt_hr": 0.23, "accel_vrw_ug_per_sqrt_hz": 70.0,
                     "init_gyro_bias_sigma_deg_per_hr": 720.0, "init_accel_bias_sigma_ug": 20000.0,
                     "init_att_sigma_arcmin": [600.0, 600.0, 6000.0], "init_pos_sigma_m": 5.0, "clock_bias_sigma_m": 30.0,
                     "clock_drift_sigma_mps": 2.0, "isb_sigma_m": 5.0, "clock_bias_psd_m2ps": 1.0,
                     "clock_drift_psd_m2ps3": 0.1, "output_rate_hz": 10.0},
          "sources": {"imu": {"type": "imu", "topic": "imu/data_raw"},
                      "gnss": {"type": "gnss_raw", "topic": "gnss/raw", "use_rates": True,
                               "signals": ["G:1C+2L,1C", "E:1C+5Q,1C", "C:6I"], "error_model": "elevation_cn0",
                               "per_satellite": True}},
          # level, heading north (roll, pitch, heading 0): C_b_n = Rz(90 deg), as a quaternion
          "initial_state": {"q_b_enu_xyzw": [0.0, 0.0, float(np.sqrt(0.5)), float(np.sqrt(0.5))]}}


@pytest.mark.graph
def test_walk_log_replays_into_live_fusion_node_as_offline(tmp_path):
    imp = {"preset": "ubx", "gnss": {"file": str(rd.real_file(rd.WALK_UBX))},
           "imu": {"file": str(rd.real_file(rd.WALK_IMU)), "time": {"column": 0, "unit": "s"}, "kind": "rates",
                   "gyro": {"columns": [4, 5, 6], "unit": "rad/s"}, "accel": {"columns": [1, 2, 3], "unit": "g"},
                   "body": "FLU"},
           "end_s": T_IMU0 + 10.0, "filter": FILTER}
    f = tmp_path / "import.yaml"
    f.write_text(yaml.safe_dump(imp))
    imported = import_data.load_import(f)
    bag = tmp_path / "bag"
    import_data.write(imported, bag)
    # the fusion node's parameters come from a scenario: the default one with the import's filter block
    # (its own sources only; the initial state written out in full, so nothing is drawn)
    filt = imported["setup"]["filter"]
    filt["initial_state"].update({"vel_enu_mps": [0.0, 0.0, 0.0], "gyro_bias_deg_per_hr": [0.0, 0.0, 0.0],
                                  "accel_bias_ug": [0.0, 0.0, 0.0]})
    sc_file = tmp_path / "walk_real.yaml"
    sc_file.write_text(yaml.safe_dump({"extends": str(REPO / "src" / "hyper_nav_sim" / "scenarios" / "default.yaml"),
                                       "name": "walk_real", "filter": filt}))
    sc = load_scenario(str(sc_file))
    recs = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(bag)]
    from hyper_nav_filter.offline import run_offline
    sols, eng = run_offline(recs, sc.filter_config(), sc.filter_initial_state(), sc.filter_sources())
    assert eng.kf.stats["pseudorange"][0] > 400 and len(sols) >= 80
    live = play_into_fusion(sc_file, bag, INPUTS, len(sols))
    for msg, sol in zip(live, sols):
        t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        assert t == pytest.approx(sol.t_s, abs=1e-6)
        assert msg.lat_rad == pytest.approx(sol.state.lat_rad, abs=1e-12)
        assert msg.lon_rad == pytest.approx(sol.state.lon_rad, abs=1e-12)
        assert msg.alt_m == pytest.approx(sol.state.alt_m, abs=1e-5)
        assert np.allclose(msg.vel_enu_mps, sol.state.vel_enu_mps, atol=1e-6)
    print(f"\nlive == offline over {len(sols)} solutions; pseudorange updates {eng.kf.stats['pseudorange']}")
