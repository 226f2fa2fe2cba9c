"""The paper scenarios fly through the real node graph: the raw GNSS
receiver (seed 004), the barometer (seed 003) and the radar (seed 002)
publish over DDS and are recorded."""
import numpy as np
import pytest

from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.report import delivery_check, load_run

pytestmark = pytest.mark.graph


def fly(tmp_path, scenario, **overrides):
    bag = tmp_path / scenario
    with Graph(scenario, record=bag, overrides=overrides, log_dir=tmp_path / f"{scenario}_logs") as g:
        g.wait_until_done()
        nodes = g.nodes
    return bag, nodes


def test_seed004_raw_gnss_over_dds(tmp_path):
    bag, nodes = fly(tmp_path, "seed004", duration_s=40.0, **{"graph.real_time_factor": 4.0})
    reader = read_bag(bag)
    recs = list(reader)
    assert reader.topics["/gnss/raw"] == "hyper_nav_msgs/msg/GnssMeasurements"
    assert reader.topics["/gnss/ephemeris"] == "hyper_nav_msgs/msg/GnssEphemeris"
    assert reader.counts["/gnss/raw"] == 40
    raw = [deserialize(r.raw, r.msgtype) for r in recs if r.topic == "/gnss/raw"]
    n_sats = [len(m.prn) for m in raw]
    assert min(n_sats) >= 6                               # GPS above the 7.5 deg mask
    assert all(not any(m.locked) for m in raw[31:])       # scripted loss of lock from 30 s
    eph = [deserialize(r.raw, r.msgtype) for r in recs if r.topic == "/gnss/ephemeris"]
    assert len({m.prn for m in eph}) >= max(n_sats)
    assert all(26000e3 ** 0.5 < m.sqrt_a_sqrtm < 27000e3 ** 0.5 for m in eph)
    run = load_run(bag)
    for topic, d in delivery_check(run).items():
        assert d["published"] == d["recorded"], (topic, d)


def test_seed003_barometer_and_seed002_radar_over_dds(tmp_path):
    # flight.duration_s: the nodes integrate 15 s of flight, not the 790 s of the scenario
    bag, nodes = fly(tmp_path, "seed003", duration_s=15.0, **{"graph.real_time_factor": 4.0, "flight.duration_s": 15.0})
    assert "baro" in nodes
    recs = [r for r in read_bag(bag) if r.topic == "/baro/pressure"]
    assert len(recs) == 15
    p = [deserialize(r.raw, r.msgtype).fluid_pressure for r in recs]
    assert 2000.0 < np.mean(p) < 3000.0                   # ~2.5 kPa at 25 km (US76)
    bag, nodes = fly(tmp_path, "seed002_s1", duration_s=15.0, **{"graph.real_time_factor": 4.0, "flight.duration_s": 15.0})
    assert "radar" in nodes
    tracks = [deserialize(r.raw, r.msgtype) for r in read_bag(bag) if r.topic == "/radar/track"]
    assert len(tracks) == 15
    assert abs(np.mean([m.altitude for m in tracks]) - 60000.0) < 3000.0
    assert tracks[0].position_covariance[8] == pytest.approx(2000.0 ** 2)


@pytest.mark.parametrize("scenario, duration_s, rtf, max_pos_m", [
    ("seed000_elastic", 12.0, 2.0, 5.0),     # 24 states: elastic lever-arm modal block, ENU
    ("seed001", 20.0, 1.0, 20.0),            # 21 states, LCI, 500 Hz IMU, through the vertical launch
])
def test_fusion_node_runs_the_paper_filter_configurations(tmp_path, scenario, duration_s, rtf, max_pos_m):
    """The fusion node takes the scenario's filter configuration as ROS
    parameters (state blocks, lever-arm model, LCI frame) and flies it live."""
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_workbench.core.scoring import errors, states_from_msgs, summarize
    bag, nodes = fly(tmp_path, scenario, duration_s=duration_s, **{"graph.real_time_factor": rtf})
    assert "fusion" in nodes
    run = load_run(bag)
    for topic, d in delivery_check(run).items():
        assert d["published"] == d["recorded"], (topic, d)
    s = summarize(errors(states_from_msgs(run["nav"]), states_from_msgs(run["truth"])), 3.0)
    print(f"\n[{scenario}] live fusion after 3 s: position RMS 3D {s['pos_enu_m']['rms_3d']:.2f} m, "
          f"velocity {s['vel_enu_mps']['rms_3d']:.3f} m/s, attitude {s['att_enu_deg']['rms_3d']:.4f} deg")
    assert s["epochs"] > 10 * (duration_s - 5.0)
    assert s["pos_enu_m"]["rms_3d"] < max_pos_m
    nav = run["nav"][-1]
    assert len(nav.state_blocks) == len(load_scenario(scenario).filter_config().state_blocks)
