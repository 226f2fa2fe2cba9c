"""RL-DLAC in the node graph (issue 13): on seed000_elastic the lever-arm node
(hyper_nav_aiding) watches nav/state against gnss/fix, fires, re-estimates
the natural frequencies in its worker process and publishes a ModelUpdate on
nav/model_update; the fusion node takes it through its declared
``model_update`` source and applies it at its epoch, and drives its modal
model with the structure's load from ``imu/load`` (its ``imu`` source's
``load_topic``). Over real DDS: the
update reaches the fusion node, the live solution equals the offline core
over the bag (late GNSS copies around the update on a second declared source
included), the lever-arm node stays responsive and the fusion node keeps
real time while the job runs (figures printed)."""
import threading
import time

import numpy as np
import pytest
from hyper_nav_msgs.msg import ModelUpdate, NavState
from rosgraph_msgs.msg import Clock
from geometry_msgs.msg import TwistWithCovarianceStamped
from sensor_msgs.msg import NavSatFix

from hyper_nav_filter.conversions import stamp_to_s
from hyper_nav_filter.offline import run_offline
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.report import delivery_check, load_run
from hyper_nav_workbench.testing import TopicCollector

pytestmark = pytest.mark.graph

DURATION_S = 30.0
RTF = 2.0
LATE_S = 0.25            # wall delay of the GNSS copies on test/late_fix (0.5 s of sim time)


class ArrivalLog:
    """Wall time of arrival of nav/state and /clock messages (the fusion
    node's lag behind the simulated clock)."""

    def __init__(self, collector):
        self.state, self.clock = [], []
        self._lock = threading.Lock()
        collector.node.create_subscription(NavState, "nav/delayed/state", self._on_state, 2000)
        collector.node.create_subscription(Clock, "/clock", self._on_clock, 2000)

    def _on_state(self, msg):
        with self._lock:
            self.state.append((time.monotonic(), stamp_to_s(msg.header.stamp)))

    def _on_clock(self, msg):
        with self._lock:
            self.clock.append((time.monotonic(), stamp_to_s(msg.clock)))

    def lag_s(self):
        """(nav/state stamp, sim time at its arrival minus its stamp)."""
        cw, cs = np.array(self.clock).T
        sw, ss = np.array(self.state).T
        return ss, np.interp(sw, cw, cs) - ss


def test_learned_model_reaches_fusion_and_live_equals_offline(tmp_path):
    overrides = {
        "duration_s": DURATION_S, "graph.real_time_factor": RTF,
        # solutions released 4 s (2 s wall) behind the newest IMU epoch, late events accepted up
        # to 6 s (3 s wall): the late copies, sent 0.25 s wall after the original reaches this
        # process, keep 1.75 s of wall margin before the release and 2.75 s before they are
        # stale when the machine is loaded (at 1 s / 3 s, 12 and 1 copies came after the release
        # in two runs beside a reproduction)
        "filter.config.output_delay_s": 4.0, "filter.config.reprocess_window_s": 6.0,
        "filter.sources.late_fix": {"type": "gnss_fix", "topic": "test/late_fix"},
        # fire as soon as a 2 s window is buffered (the residual statistic of 5 m fixes is ~2 m)
        "lever_arm_learning.trigger": {"threshold_m": 0.5, "release_m": 0.2, "cooldown_s": 1000.0,
                                       "averaging_s": 1.0},
        "lever_arm_learning.window_s": 2.0, "lever_arm_learning.state_period_s": 0.5,
        # Nelder-Mead on the reward (no jax in the worker; the best state visited improves on the
        # model in force, so it is published): the plumbing is under test here, DDPG in the core tests
        "lever_arm_learning.method": "nelder_mead", "lever_arm_learning.budget_passes": 10,
        "lever_arm_learning.timeout_s": 60.0,
    }
    bag = tmp_path / "bag"
    extra = {"gnss/fix": 1, "gnss/vel": 1, "/clock": 1}     # the gnss node waits for all its topics
    with Graph("seed000_elastic", record=bag, overrides=overrides, extra_subscribers=extra,
               log_dir=tmp_path / "logs") as g:
        assert "lever_arm" in g.nodes
        with TopicCollector({"gnss/fix": NavSatFix, "gnss/vel": TwistWithCovarianceStamped,
                             "nav/model_update": ModelUpdate}, domain_id=g.domain_id, name="late_fix_source") as c:
            # the clock waits for this test's /clock subscription (ArrivalLog), made once the late-copy
            # publisher is matched by the recorder and the fusion node: a copy published before its
            # readers match can be lost (a fresh-clone run: 299 of 300 received, none rejected)
            pub = c.publisher(NavSatFix, "test/late_fix")
            deadline = time.monotonic() + 60.0
            while pub.get_subscription_count() < 2:
                g.check_alive()
                assert time.monotonic() < deadline, "test/late_fix: recorder and fusion never subscribed"
                time.sleep(0.05)
            time.sleep(1.0)                     # discovery is asymmetric: let the readers match too
            arrivals = ArrivalLog(c)
            sent, timers = 0, []
            truth = g.procs["truth"]
            while truth.poll() is None:
                g.check_alive()
                with c._lock:
                    fixes = list(c.messages["gnss/fix"])
                for m in fixes[sent:]:
                    timers.append(threading.Timer(LATE_S, pub.publish, (m,)))
                    timers[-1].start()
                sent = len(fixes)
                time.sleep(0.02)
            for t in timers:            # every late copy is out (a loaded machine delays timer threads)
                t.join()
            time.sleep(2 * LATE_S)
            g.wait_until_done()
            updates = list(c.messages["nav/model_update"])
    run = load_run(bag)
    delivery = delivery_check(run)
    for topic in ("imu/data_raw", "imu/load", "gnss/fix", "gnss/vel"):      # the inputs of the live = offline check
        assert delivery[topic]["published"] == delivery[topic]["recorded"] > 0, (topic, delivery[topic])

    # the node fired once, re-estimated off its callback thread and published one update
    node = run["diagnostics"]["hyper_nav_aiding: lever_arm_learning"]
    print("\nlever_arm node:", {k: v for k, v in node.items() if k.startswith(("jobs", "callback", "last", "trigger"))})
    assert int(node["jobs_started"]) == int(node["jobs_accepted"]) == int(node["model_updates_published"]) == 1
    assert len(updates) == 1
    upd = updates[0]
    assert upd.model == "lever_arm" and list(upd.names) == ["lever_arm_natural_freq_radps"] * 3
    assert len(upd.values) == 3 and len(upd.sigmas) == 3 and np.all(np.asarray(upd.values) > 0)
    t_update = stamp_to_s(upd.header.stamp)
    assert 4.0 < t_update < DURATION_S - 2.0

    # the fusion node took it through its declared source
    fusion = run["diagnostics"]["hyper_nav_filter: fusion"]
    assert int(fusion["processed nav/model_update"]) == 1
    # and the structure's load (imu/load, 8 samples per IMU interval) with every IMU sample
    assert int(fusion["received imu/load"]) == 8 * int(fusion["received imu/data_raw"]) > 0
    assert "processed imu/data_raw (without load)" not in fusion
    print("fusion, late copies:", {k: v for k, v in fusion.items() if "test/late_fix" in k or "late" in k},
          "sent", sent)
    # every late copy reached the node; one that came after its epoch's release (a loaded machine)
    # is still applied, one older than the reprocess window rejected as stale: counted either way
    stale = int(fusion.get("rejected test/late_fix (gnss_pos_stale)", 0))
    assert int(fusion["received test/late_fix"]) == sent > 100
    assert int(fusion["processed test/late_fix"]) + stale == sent

    # live = offline over the bag, bit for bit (late fixes and the update included): stamp order,
    # and each input the node received behind the IMU (nav/late_inputs) where it received it
    sc = g.scenario
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(bag)
               if r.topic in ("/imu/data_raw", "/imu/load", "/gnss/fix", "/gnss/vel", "/test/late_fix",
                              "/nav/model_update", "/nav/late_inputs")]
    sols, eng = run_offline(records, sc.filter_config(), sc.filter_initial_state(), sc.filter_sources(), final=True)
    # every input the node reported late was found in the bag and placed where the node took it (how many
    # of the late copies were behind the IMU at the node depends on scheduling: not asserted)
    assert eng.replay.missing == () and eng.replay.placed == int(fusion["published nav/late_inputs"]) > 0
    live = run["nav"]
    assert len(live) == len(sols) > 40 * (DURATION_S - 2)
    assert eng.counters["model_update_received"] == 1 and eng.counters["gnss_pos_late"] > 0
    for msg, sol in zip(live, sols):
        assert stamp_to_s(msg.header.stamp) == pytest.approx(sol.t_s, abs=1e-9)
        assert (msg.lat_rad, msg.lon_rad, msg.alt_m) == (sol.state.lat_rad, sol.state.lon_rad, sol.state.alt_m)
        assert np.array_equal(np.asarray(msg.vel_enu_mps), sol.state.vel_enu_mps)
    # the update changed the solution from its epoch on (vs the offline core without it)
    base, _ = run_offline([r for r in records if r[0] != "/nav/model_update"], sc.filter_config(),
                          sc.filter_initial_state(), sc.filter_sources(), final=True)
    dv = [np.abs(a.state.vel_enu_mps - b.state.vel_enu_mps).max() for a, b in zip(sols, base)]
    t = np.array([s.t_s for s in sols])
    assert max(dv[i] for i in np.flatnonzero(t < t_update - 1e-6)) == 0.0
    assert max(dv[i] for i in np.flatnonzero(t > t_update + 0.1)) > 0.0

    # responsiveness (figures, not a timed test): the lever-arm node's callbacks while the job ran
    # and the fusion node's lag behind the simulated clock with and without a job running
    ts, lag = arrivals.lag_s()
    t_trig = float(node["last_trigger_t_s"])
    during = (ts > t_trig + 1.0) & (ts < t_update - 1.0)
    others = ~during & (ts > 2.0)
    print(f"lever_arm callbacks while the job ran: {node['callback_busy_count']}, mean "
          f"{node['callback_busy_mean_ms']} ms, max {node['callback_busy_max_ms']} ms (idle: mean "
          f"{node['callback_idle_mean_ms']} ms, max {node['callback_idle_max_ms']} ms); job "
          f"{node['last_reestimation'].split('(')[-1]}; fusion nav/state lag behind /clock (output delay "
          f"{sc.filter_config().output_delay_s} s): during the job median {np.median(lag[during]):.3f} s, max "
          f"{lag[during].max():.3f} s; otherwise median {np.median(lag[others]):.3f} s, max {lag[others].max():.3f} s")
    # the node kept taking its inputs while the job ran in the worker process (how many depends on the
    # job's wall time, and a callback's wall time on the machine's load: figures printed above, not asserted)
    assert int(node["callback_busy_count"]) > 0
    assert during.sum() > 50
