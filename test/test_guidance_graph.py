"""Guidance in the loop over real DDS (issue 36): the truth node flies the
guidance node's commands live, under the clock gate.

* guidance on ``truth/state``: every truth sample of the live flight equals
  the offline loop's (``closed_loop.fly_on_truth``, the same cores) bit for
  bit, every command the guidance node sent equals the offline one, the truth
  node accepted them all (none refused, none missed), and the flight reached
  the target within the law's tolerance;
* guidance on the fusion node's current-time state (``nav/state``, the
  scenario's default): the sensor nodes fly the steered flight from
  ``flight/steps`` (their IMU and GNSS messages are those of the flight the
  truth node flew, bit for bit), nothing is lost, and the offline loop
  (``closed_loop.fly_on_navigation``) fed the recorded late inputs where
  they arrived gives the recorded commands and truth bit for bit;
* no command publisher: the scenario's program flies (truth/state equals
  the scheduled flight), and commands out of range sent to it are refused
  and counted on /diagnostics, changing nothing.
"""
import math
import time

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from hyper_nav_msgs.msg import GlideCommand, GnssMeasurements, NavState

from hyper_nav_filter.conversions import stamp_to_s
from hyper_nav_filter.ros_util import publisher_qos
from hyper_nav_guidance.closed_loop import (bag_loop, fly_on_navigation, fly_on_truth, late_inputs_of,
                                           replay_commands, truth_epochs)
from hyper_nav_sim.core.flown_streams import FlownFixes, FlownImu, FlownRaw
from hyper_nav_sim.core.boost_glide import DynamicTrajectory
from hyper_nav_sim.core.boost_glide_config import parse_flight
from hyper_nav_sim.core.guidance_config import GuidanceConfig

pytestmark = pytest.mark.graph
ON_TRUTH = {"guidance.nav_topic": "truth/state", "guidance.nav_type": "navstate", "duration_s": 114.0,   # (its default)
            "graph.real_time_factor": 10.0}


def _truth_status(msgs):
    """The truth node's last /diagnostics values."""
    last = None
    for arr in msgs:
        for st in arr.status:
            if st.name == "hyper_nav_sim: truth":
                last = {kv.key: kv.value for kv in st.values}
    return last


def _truth_arrays(msgs):
    t = np.array([stamp_to_s(m.header.stamp) for m in msgs])
    x = np.array([[m.lat_rad, m.lon_rad, m.alt_m, *m.vel_enu_mps] for m in msgs])
    return t, x


def test_guidance_on_truth_live_equals_offline(hyper_nav_graph):
    run = hyper_nav_graph("guidance_glide", overrides=ON_TRUTH, nodes=("truth", "guidance"),
                          topics={"truth/state": NavState, "guidance/command": GlideCommand,
                                  "/diagnostics": DiagnosticArray})
    offline = fly_on_truth(run.scenario)
    t, x = _truth_arrays(run.messages["truth/state"])
    tr = offline.flight
    assert len(t) > 5000 and t[-1] <= tr.duration_s and t[-1] > tr.duration_s - 0.03
    # the truth node's epochs (k / clock_rate_hz), not their stamps' round trip through (sec, nanosec)
    sc = run.scenario
    base = 1.0 / sc["graph.clock_rate_hz"]
    every = max(1, int(round(sc["graph.clock_rate_hz"] / sc["graph.truth_rate_hz"])))
    steps = np.arange(0, len(t) * every, every)
    t_node = steps * base
    assert np.abs(t_node - t).max() < 1e-9
    want = np.array([[*(float(v) for v in (s.lat_rad[0], s.lon_rad[0], s.alt_m[0])), *s.vel_enu_mps[0]]
                     for s in (tr.truth(t_node[i:i + 1]) for i in range(len(t)))])
    status = _truth_status(run.messages["/diagnostics"])
    assert np.array_equal(x, want), f"max |diff| {np.abs(x - want).max(axis=0)}; truth node: {status}"
    sent = {stamp_to_s(m.header.stamp): (m.bank_rad, m.c_l) for m in run.messages["guidance/command"]}
    computed = {c[0]: (c[1], c[2]) for c in offline.commands}
    assert len(sent) > 1000 and all(sent[k] == computed[k] for k in sent)
    assert status is not None
    # every command that applies before the flight's end was taken (the last one, due after it, may
    # come after the truth node stopped listening)
    due = sum(1 for c in offline.commands if tr.apply_step(c[0]) * tr.step_s < tr.duration_s)
    assert due <= int(status["commands accepted"]) == int(status["commands received"]) <= len(offline.commands)
    assert int(status["commands missed"]) == 0 and not any(k.startswith("commands refused") for k in status)
    cfg = GuidanceConfig.from_config(run.scenario.data["guidance"])
    assert offline.miss["miss_m"] < cfg.miss_tolerance_m


def _bag_rows(bag, topic):
    from hyper_nav_workbench.core.bag import deserialize, read_bag
    rows = []
    for rec in read_bag(bag, topics=(topic,)):
        m = deserialize(rec.raw, rec.msgtype)
        if topic == "/imu/data_raw":
            w, a = m.angular_velocity, m.linear_acceleration
            rows.append((stamp_to_s(m.header.stamp), w.x, w.y, w.z, a.x, a.y, a.z))
        else:
            rows.append((stamp_to_s(m.header.stamp), m.latitude, m.longitude, m.altitude))
    return np.array(sorted(rows))


def _assert_offline_equals(run, cmds, truth):
    """The offline loop fed the run's late inputs where they arrived: the recorded commands and truth, bit for bit."""
    sc = run.scenario
    off = fly_on_navigation(sc, "current", late_inputs=late_inputs_of(run.bag))
    assert np.array_equal(np.array(cmds), np.array(off.commands[:len(cmds)])), "commands differ"
    t_truth = truth_epochs(sc, len(truth))
    want = np.array([[s.lat_rad[0], s.lon_rad[0], s.alt_m[0], *s.vel_enu_mps[0]]
                     for s in (off.flight.truth(t_truth[i:i + 1]) for i in range(len(t_truth)))])
    assert np.array_equal(truth, want)


def _loop_run(hyper_nav_graph, scenario, duration_s, topics):
    """A recorded navigation loop: (run, its truth node's last status, commands, truth rows)."""
    run = hyper_nav_graph(scenario, overrides={"duration_s": duration_s, "graph.real_time_factor": 5.0},
                          record=True, topics={"/diagnostics": DiagnosticArray, **topics})
    return (run, _truth_status(run.messages["/diagnostics"]), *bag_loop(run.bag))


def test_guidance_on_navigation_live_equals_offline(hyper_nav_graph):
    run, status, cmds, truth = _loop_run(hyper_nav_graph, "guidance_glide", 10.0, {"guidance/command": GlideCommand})
    sc = run.scenario
    # the loop went round on navigation: a command for every grid stamp 1.0 .. 10.0 s, all taken, none missed
    assert len(cmds) == 91 and int(status["commands accepted"]) == int(status["commands received"]) == 91
    assert int(status["commands missed"]) == 0 and not any(k.startswith("commands refused") for k in status)
    # the sensors flew the flight the truth node flew (the commands' flight), bit for bit
    flight = replay_commands(sc, cmds).flight
    imu = FlownImu(sc, flight)
    t, dth, dv = imu.until_flown()
    want = np.column_stack([t, dth / imu.dt_s, dv / imu.dt_s])[t <= sc["duration_s"] + 1e-9]
    got = _bag_rows(run.bag, "/imu/data_raw")
    assert got.shape == want.shape == (500, 7)
    assert np.array_equal(got[:, 1:], want[:, 1:]) and np.abs(got[:, 0] - want[:, 0]).max() < 1e-9
    fixes = FlownFixes(sc, flight).until(sc["duration_s"])
    got = _bag_rows(run.bag, "/gnss/fix")
    assert len(got) == len(fixes) == 100
    assert np.array_equal(got[:, 3], [float(g.alt_m[0]) for g in fixes])
    assert np.array_equal(got[:, 1], [float(np.rad2deg(g.lat_rad[0])) for g in fixes])
    # ... which is not the scheduled program's: the guidance steered it (tens of m off at 10 s)
    prog = DynamicTrajectory(**parse_flight(dict(sc.data["flight"]))).truth(np.array([10.0]))
    assert abs(flight.truth(np.array([10.0])).alt_m[0] - prog.alt_m[0]) > 10.0 or \
        abs(flight.truth(np.array([10.0])).lat_rad[0] - prog.lat_rad[0]) * 6.4e6 > 10.0
    # live == offline on the recorded bag: the same cores, the inputs where they arrived live
    assert len(truth) == 501
    _assert_offline_equals(run, cmds, truth)


def test_guidance_on_navigation_with_the_raw_receiver_live_equals_offline(hyper_nav_graph):
    """The realistic world: the GNSS node's receiver (gnss.raw) on the steered flight, each epoch once
    the flight is flown past it (FlownRaw); its fixes loosely coupled. Nothing lost, every command
    taken, the receiver's epochs those of the recorded flight, live == offline bit for bit."""
    run, status, cmds, truth = _loop_run(hyper_nav_graph, "guidance_glide_realistic", 6.0,
                                         {"gnss/raw": GnssMeasurements})
    sc = run.scenario
    assert len(cmds) == 51 and int(status["commands accepted"]) == 51 and int(status["commands missed"]) == 0
    flight = replay_commands(sc, cmds).flight
    epochs = FlownRaw(sc, flight).until(sc["duration_s"])
    raw = sorted(run.messages["gnss/raw"], key=lambda m: stamp_to_s(m.header.stamp))
    assert len(raw) == len(epochs) == 60
    assert all(list(m.pseudorange_m) == [float(x) for x in e.pseudorange_m] for m, e in zip(raw, epochs))
    got = _bag_rows(run.bag, "/gnss/fix")
    with_fix = [e for e in epochs if e.fix is not None]
    assert len(got) == len(with_fix) >= 54
    assert np.array_equal(got[:, 3], [float(e.fix.alt_m) for e in with_fix])
    _assert_offline_equals(run, cmds, truth)


def test_no_command_topic_program_flies_and_bad_commands_are_refused(hyper_nav_graph):
    over = {"duration_s": 20.0, "graph.real_time_factor": 1.0}
    live = hyper_nav_graph.start("guidance_glide", overrides=over, nodes=("truth",),
                                 topics={"truth/state": NavState, "/diagnostics": DiagnosticArray})
    # the clock started without a command publisher (the first truth sample is out): nothing waits for commands
    for _ in range(2400):
        if live.messages["truth/state"]:
            break
        time.sleep(0.05)
    ctx = rclpy.context.Context()
    rclpy.init(context=ctx, domain_id=live.domain_id)
    try:
        node = rclpy.create_node("bad_guidance", context=ctx)
        pub = node.create_publisher(GlideCommand, "guidance/command", publisher_qos(10))
        while pub.get_subscription_count() < 1:
            time.sleep(0.05)                          # discovery runs in the middleware
        for bank, c_l in ((2.0, 1.0), (0.1, 9.0), (0.1, float("nan"))):
            m = GlideCommand()
            m.header.stamp.sec = 1
            m.bank_rad, m.c_l = bank, c_l
            pub.publish(m)
        run = live.wait()
    finally:
        rclpy.try_shutdown(context=ctx)
    status = _truth_status(run.messages["/diagnostics"])
    assert int(status["commands received"]) == 3 and int(status["commands accepted"]) == 0
    assert int(status["commands refused bank_out_of_range"]) == 1
    assert int(status["commands refused c_l_out_of_range"]) == 1
    assert int(status["commands refused not_finite"]) == 1
    # the scheduled program flew: truth/state is the program's flight (integrated in other steps: 1e-4 m)
    t, x = _truth_arrays(run.messages["truth/state"])
    assert len(t) == int(round(20.0 * run.scenario["graph.truth_rate_hz"])) + 1
    fl = dict(run.scenario.data["flight"])
    prog = DynamicTrajectory(**parse_flight(fl)).truth(t)
    assert np.abs(x[:, 2] - prog.alt_m).max() < 1e-4
    assert np.abs((x[:, 0] - prog.lat_rad) * 6.4e6).max() < 1e-4
    assert np.abs(x[:, 3:] - prog.vel_enu_mps).max() < 1e-7
    assert math.isfinite(x[-1, 2])


def test_fixture_flies_a_guidance_node_on_the_current_time_state(hyper_nav_guidance_loop):
    """The user fixture on nav/state: the graph with the sensors and the fusion node, a guidance node
    (here the project's own executable, as a user would pass theirs) in the loop; every command taken,
    the live flight the commands' flight bit for bit, and the same commands as the offline loop fed
    the run's late inputs."""
    run = hyper_nav_guidance_loop(("hyper_nav_guidance", "guidance_node"), scenario="guidance_glide",
                                  overrides={"duration_s": 10.0, "graph.real_time_factor": 5.0},
                                  nav_topic="nav/state")
    assert run.replay_equal
    assert int(run.truth_node["commands missed"]) == 0 and int(run.truth_node["commands accepted"]) == 91
    assert not any(k.startswith("commands refused") for k in run.truth_node)
    off = fly_on_navigation(run.run.scenario, "current", late_inputs=late_inputs_of(run.bag))
    assert np.array_equal(np.array(run.commands), np.array(off.commands[:len(run.commands)]))
