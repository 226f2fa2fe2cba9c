"""Seed 002 over DDS: radar_node -> tracker_node (trained L-EKF). The
tracker's estimates equal the offline core's on the same radar stream, track
the truth, and bad radar messages injected on radar/track are rejected and
counted on /diagnostics."""
import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistWithCovarianceStamped
from sensor_msgs.msg import NavSatFix

from hyper_nav_filter.conversions import s_to_stamp_fields, stamp_to_s
from hyper_nav_filter.core.target_tracking import params_store
from hyper_nav_filter.core.target_tracking.tracker import Tracker
from hyper_nav_sim.core.tracking_setup import radar_epochs, radar_measurements, scenario_track, tracker_config
from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.testing import TopicCollector

pytestmark = pytest.mark.graph
DURATION_S = 40.0


def _final_counters(diags):
    vals = {}
    for arr in diags:
        for st in arr.status:
            if st.name == "hyper_nav_filter: tracker":
                vals = {kv.key: kv.value for kv in st.values}
    return vals


def test_radar_to_lekf_tracker_over_dds():
    topics = {"track/fix": NavSatFix, "track/vel": TwistWithCovarianceStamped, "/diagnostics": DiagnosticArray}
    with Graph("seed002_s1", nodes=("truth", "radar", "tracker"),
               overrides={"duration_s": DURATION_S, "graph.real_time_factor": 8.0},
               extra_subscribers={"track/fix": 1, "track/vel": 1}) as g:
        sc = g.scenario
        with TopicCollector(topics, domain_id=g.domain_id) as c:
            inject = c.publisher(NavSatFix, "radar/track")
            assert c.wait_for(lambda m: len(m["track/fix"]) >= 5, timeout_s=120.0), g.log("tracker")[-2000:]
            t_last = stamp_to_s(c.messages["track/fix"][-1].header.stamp)
            bad = NavSatFix()                                    # NaN latitude
            bad.header.stamp.sec, bad.header.stamp.nanosec = s_to_stamp_fields(t_last + 0.5)
            bad.latitude, bad.longitude, bad.altitude = float("nan"), 1.0, 50e3
            inject.publish(bad)
            old = NavSatFix()                                    # valid numbers, stamp in the past
            old.header.stamp.sec, old.header.stamp.nanosec = s_to_stamp_fields(1.0)
            old.latitude, old.longitude, old.altitude = 0.0, 0.0, 60e3
            inject.publish(old)
            g.wait_until_done()
    fixes, vels = c.messages["track/fix"], c.messages["track/vel"]
    t = radar_epochs(sc)
    assert len(fixes) == len(vels) == len(t) == int(DURATION_S)
    assert [stamp_to_s(m.header.stamp) for m in fixes] == pytest.approx(list(t))
    counters = _final_counters(c.messages["/diagnostics"])
    assert counters["filter_type"] == "LEKF"
    assert int(counters["rejected_radar_nan"]) == 1 and int(counters["rejected_radar_out_of_order"]) == 1
    assert int(counters["accepted"]) == len(t)
    # the live node and the offline core on the same radar stream give the same track
    cfg = tracker_config(sc)
    arch, variables, _ = params_store.load(cfg.lekf_parameters)
    from hyper_nav_sim.core.tracking_setup import initial_truth
    trk = Tracker(cfg, cfg.initial_estimate(initial_truth(sc)), 0.0, 1.0, (arch, variables))
    Z = radar_measurements(sc, sc.rng("radar"))
    offline = []
    for k in range(len(t)):
        assert trk.add_measurement(t[k], Z[k]) is None
        offline.append(trk.last.x)
    offline = np.array(offline)
    live = np.array([[m.altitude, np.deg2rad(m.longitude), np.deg2rad(m.latitude)] for m in fixes])
    d = np.abs(live - offline[:, :3]).max(axis=0)
    assert np.all(d < [1e-3, 1e-9, 1e-9]), d
    # and it tracks the truth far better than the radar's 2000 m / 0.01 rad (64 km)
    truth = scenario_track(sc).x
    err = live - truth[:, :3]
    assert np.sqrt(np.mean(err[:, 0] ** 2)) < 1000.0
    assert np.sqrt(np.mean(err[:, 1] ** 2 + err[:, 2] ** 2)) < 2.0e-3
    speed = np.array([np.linalg.norm([v.twist.twist.linear.x, v.twist.twist.linear.y, v.twist.twist.linear.z])
                      for v in vels])
    assert np.sqrt(np.mean((speed - truth[:, 3]) ** 2)) < 150.0
    assert all(m.position_covariance_type == NavSatFix.COVARIANCE_TYPE_KNOWN and m.position_covariance[8] > 0
               for m in fixes)
