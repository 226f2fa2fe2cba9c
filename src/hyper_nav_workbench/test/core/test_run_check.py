"""The report's checks: expected solution epochs (the engine's release rule),
gaps, losses between publisher, recorder and fusion, stopped streams,
/diagnostics faults and dead nodes."""
import functools

import numpy as np
import pytest

from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_workbench.core import run_check
from hyper_nav_sim.core.scenario import load_scenario


@functools.lru_cache(maxsize=1)
def _default():
    sc = load_scenario("default")
    sc.trajectory()
    return sc


@pytest.mark.parametrize("imu_hz,out_hz", [(50.0, 50.0), (100.0, 50.0), (500.0, 50.0), (100.0, 30.0)])
def test_release_epochs_match_the_fusion_engine(imu_hz, out_hz):
    """The same epochs as FusionEngine.release over a real (error-free) IMU stream."""
    sc = _default()
    cfg = sc.filter_config()
    cfg = type(cfg).from_dict(dict({k: getattr(cfg, k) for k in ("state_blocks",)}, output_rate_hz=out_hz))
    traj = sc.trajectory()
    dt = 1.0 / imu_hz
    t = np.arange(1, int(2.0 * imu_hz) + 1) * dt
    dth, dv = traj.imu_increments(t, dt)
    eng = FusionEngine(cfg, sc.filter_initial_state())
    sols = []
    for k in range(len(t)):
        eng.add_imu(t[k], dth[k], dv[k])
        sols += eng.release()
    sols += eng.release(final=True)
    np.testing.assert_allclose(run_check.release_epochs(t, out_hz), [s.t_s for s in sols], atol=1e-12)


def test_expected_scored_epochs_of_a_short_default_run():
    """10 s at 50 Hz IMU, output and truth, scored from 2 s: 2.00 .. 10.00 s = 401 epochs."""
    e = run_check.expected_scored_epochs(10.0, 50.0, 50.0, 50.0, 2.0)
    assert len(e) == 401 and e[0] == pytest.approx(2.0) and e[-1] == pytest.approx(10.0)
    # truth at 10 Hz: only the common epochs count
    assert len(run_check.expected_scored_epochs(10.0, 50.0, 50.0, 10.0, 2.0)) == 81


def test_epoch_check_groups_gaps():
    expected = np.arange(1, 501) * 0.02
    scored = np.concatenate([expected[:100], expected[350:]])       # 5 s missing from 2.02 s
    out = run_check.Outcome()
    d = run_check.epoch_check(scored[::-1], expected, out)          # order does not matter
    assert (d["expected"], d["scored"], d["missing"]) == (500, 250, 250)
    assert d["gaps"] == [{"from_s": pytest.approx(2.02), "to_s": pytest.approx(7.0), "epochs": 250}]
    assert out.failures == ["epochs: 250 of 500 expected solution epochs present; 250 missing in 1 gap(s): "
                            "2.02-7.00 s (250)"]
    ok = run_check.Outcome()
    run_check.epoch_check(expected, expected, ok)
    assert ok.verdict == "PASS"


def _last(imu_pub=1000, rec=None, received=1000, processed=1000):
    return {"imu": {"published imu/data_raw": str(imu_pub), "scheduled imu/data_raw": "1000"},
            "fusion": {"received imu/data_raw": str(received), "processed imu/data_raw": str(processed),
                       "published nav/state": "950", "rejected_imu_nan": "0"}}


def test_nothing_lost_passes():
    out = run_check.Outcome()
    rows = run_check.delivery_rows(_last(), {"/imu/data_raw": 1000, "/nav/state": 950}, out)
    run_check.schedule_rows(_last(), out)
    run_check.rejected_inputs(_last()["fusion"], out)
    assert out.verdict == "PASS", out.failures
    assert rows["imu/data_raw"] == {"published": 1000, "publisher": "imu", "received_by_fusion": 1000,
                                    "processed_by_fusion": 1000, "recorded": 1000}


@pytest.mark.parametrize("kw,recorded,expect", [
    ({}, 990, "delivery: imu/data_raw: published 1000, recorded 990 (+10 between publisher and recorder)"),
    ({"received": 4141}, 1000, "inputs: imu/data_raw: published 1000, received by fusion 4141"),
    ({"received": 900, "processed": 900}, 1000, "inputs: imu/data_raw: published 1000, received by fusion 900 (+100 "
                                                "on the way to fusion)"),
    ({"processed": 990}, 1000, "inputs: imu/data_raw: received by fusion 1000, processed 990 (10 not used"),
    ({"imu_pub": 600}, 600, "streams: imu published 600 of the 1000 imu/data_raw messages of its scenario"),
])
def test_losses_fail(kw, recorded, expect):
    out = run_check.Outcome()
    last = _last(**kw)
    run_check.delivery_rows(last, {"/imu/data_raw": recorded, "/nav/state": 950}, out)
    run_check.schedule_rows(last, out)
    assert out.verdict == "FAIL" and any(f.startswith(expect) for f in out.failures), out.failures


def test_dead_publisher_counts_are_a_lower_bound():
    """A killed sensor's last status lags what it published: more recorded and
    received than it reported is not a loss; less would be."""
    last = _last(imu_pub=400, received=430, processed=430)
    out = run_check.Outcome()
    run_check.delivery_rows(last, {"/imu/data_raw": 430, "/nav/state": 950}, out, dead={"imu"})
    assert not [f for f in out.failures if f.startswith(("delivery", "inputs"))], out.failures
    out = run_check.Outcome()
    run_check.delivery_rows(_last(imu_pub=400, received=380, processed=380), {"/imu/data_raw": 430}, out,
                            dead={"imu"})
    assert any("received by fusion 380" in f for f in out.failures)


def test_bridged_imu_gaps_fail():
    out = run_check.Outcome()
    assert run_check.bridged_gaps({"imu_gaps": "1", "imu_gap_total_s": "5.0"}, out) == 1
    assert out.failures == ["inputs: fusion bridged 1 IMU gap(s), 5.00 s without IMU data"]
    assert run_check.bridged_gaps({}, run_check.Outcome()) == 0


def test_rejected_inputs_fail():
    out = run_check.Outcome()
    run_check.rejected_inputs({"rejected_imu_nan": "10", "rejected_imu_out_of_order": "3", "imu_msgs": "5"}, out)
    assert out.failures == ["inputs: fusion rejected input messages: imu_nan 10, imu_out_of_order 3"]


def test_status_faults_dead_node_and_warnings():
    P = run_check.MONITOR_PREFIX
    timeline = {
        P + "node gnss": [(3.0, 0, "alive", {}), (21.0, 2, "dead: no heartbeat for 5.2 s, last at t = 8.1 s",
                                                 {"since_t_s": "8.100"})],
        P + "stream gnss/fix": [(3.0, 0, "ok", {}), (21.0, 1, "lost", {"since_t_s": "8.100"})],
        P + "stream imu/data_raw": [(9.0, 2, "missing", {"since_t_s": "6.000"}), (12.0, 0, "ok", {})],
        P + "node imu": [(9.0, 2, "dead: no heartbeat", {"since_t_s": "6.000"})],
        "hyper_nav_sim: monitor": [(21.0, 2, "node gnss: dead", {})],
    }
    exits = [{"node": "gnss", "ros_name": "gnss", "how": "killed by SIGKILL", "t_wall_s": 8.0}]
    out = run_check.Outcome()
    faults = run_check.status_faults(timeline, out, exits)
    assert {f["name"] for f in faults} == {P + "node gnss", P + "stream gnss/fix", P + "stream imu/data_raw",
                                           P + "node imu"}
    assert "nodes: 'gnss' died (killed by SIGKILL) 8.0 s after the start (wall); last heartbeat at t = 8.1 s" \
        in out.failures
    assert any(f.startswith("monitor: node imu: ERROR from t = 6.0 s") for f in out.failures)   # never recovered
    assert any("stream imu/data_raw: ERROR from t = 6.0 s: missing (recovered)" in w for w in out.warnings)
    assert any("stream gnss/fix: WARN from t = 8.1 s" in w for w in out.warnings)
