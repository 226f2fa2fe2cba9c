"""The receiver's aiding loop closed over DDS (issue 23): scenario
seed004_blackout with ``gnss.raw.tracking.aiding_source: nav_state`` and an
OCXO receiver clock. gnss_node takes the fusion node's nav/state (with
covariance) as it arrives, computes each receiver epoch when it is released
with the state it holds then, and its channels run aided (tracking flag 16)
once it holds a fresh state and has its own first fix; a test publisher's
bad states (NaN, a covariance that is not PSD) on the same topic are refused
and counted on /diagnostics; the fusion node's solution stays on truth."""
import math
import threading
import time

import numpy as np
import pytest

from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.core.scoring import errors, states_from_msgs, summarize
from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.report import delivery_check, load_run

pytestmark = pytest.mark.graph

DURATION_S = 20.0
OVERRIDES = {"duration_s": DURATION_S, "graph.real_time_factor": 2.0,
             "gnss.raw.tracking.aiding_source": "nav_state",
             "gnss.raw.clock": {"h0": 8e-20, "h_m2": 4e-23},           # OCXO: see test_aiding.py
             # the fusion node releases its states output_delay_s behind the IMU (default 1 s, to take
             # late inputs); in the boost (jerk ~2 m/s^3) a 1 s old state puts the prediction 3 sigma off
             # on 99 of 176 channel-epochs (measured); 0.1 s: the aiding is 0.1-0.2 s old
             "filter.config.output_delay_s": 0.1,
             # a 30 dB sheath over 6-15 s instead of 50 dB over 90-190 s: short run
             "gnss.raw.tracking.signal.plasma": {"mode": "table", "t_s": [6.0, 9.0, 12.0, 15.0],
                                                 "att_db": [0.0, 30.0, 30.0, 0.0]}}


def _bad_states(stop):
    """Publish NavState messages that must be refused: NaN velocity, then a
    covariance with a negative variance; 2 of each, 1 s of wall time apart."""
    import rclpy
    from rclpy.context import Context
    from hyper_nav_msgs.msg import NavState
    ctx = Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node("bad_aiding_publisher", context=ctx)
    pub = node.create_publisher(NavState, "nav/delayed/state", 10)
    try:
        deadline = time.monotonic() + 20.0
        while pub.get_subscription_count() < 2 and time.monotonic() < deadline and not stop.is_set():
            time.sleep(0.1)
        time.sleep(3.0)
        for k in range(4):
            m = NavState()
            m.header.stamp.sec = 1 + k
            m.lat_rad, m.lon_rad, m.alt_m = 0.46, 2.08, 30000.0
            m.q_b_enu.w = 1.0
            m.state_blocks = ["att:3", "vel:3", "pos:3"]
            m.state_dim = 9
            P = np.eye(9)
            if k % 2 == 0:
                m.vel_enu_mps = [math.nan, 0.0, 0.0]
            else:
                m.vel_enu_mps = [2000.0, 0.0, 0.0]
                P[4, 4] = -1.0
            m.covariance = P.ravel().tolist()
            pub.publish(m)
            time.sleep(1.0)
    finally:
        node.destroy_node()
        rclpy.shutdown(context=ctx)


def test_receiver_aided_by_the_fusion_state_over_dds(tmp_path):
    bag = tmp_path / "seed004_blackout_loop"
    stop = threading.Event()
    th = threading.Thread(target=_bad_states, args=(stop,), daemon=True)
    with Graph("seed004_blackout", record=bag, log_dir=tmp_path / "logs", overrides=OVERRIDES) as g:
        th.start()
        g.wait_until_done()
        sc = g.scenario
    stop.set()
    th.join(timeout=10.0)
    run = load_run(bag)
    delivery = delivery_check(run)
    for topic in ("gnss/raw", "gnss/fix"):
        assert delivery[topic]["published"] == delivery[topic]["recorded"] > 0, (topic, delivery[topic])
    # nav/delayed/state (gnss_node's aiding input): the fusion node's plus the test's 4 bad ones (9-state layout,
    # left out of the scoring)
    assert delivery["nav/delayed/state"]["recorded"] == delivery["nav/delayed/state"]["published"] + 4 > 4, \
        delivery["nav/delayed/state"]
    nav = [m for m in run["nav"] if m.state_dim != 9]
    gnss = run["diagnostics"]["hyper_nav_sim: gnss"]
    aid = {k[len("aiding "):]: float(v) for k, v in gnss.items() if k.startswith("aiding ")}
    print(f"\ngnss_node aiding counters: {aid}")
    # bad states refused and counted (a NaN one, a non-PSD one, twice each)
    assert aid["rejected_nan"] == 2 and aid["rejected_cov"] == 2, aid
    assert aid["accepted"] > 10 * DURATION_S             # the fusion node's states (50 Hz) arrive
    raw = [deserialize(r.raw, r.msgtype) for r in read_bag(bag) if r.topic == "/gnss/raw"]
    aided = [bool(np.all(np.asarray(m.tracking_flags) & 16)) for m in raw]
    print(f"gnss/raw epochs {len(raw)}, aided {sum(aided)}; flags per epoch "
          f"{[list(m.tracking_flags)[:3] for m in raw]}")
    assert len(raw) >= int(DURATION_S)
    assert not aided[0]                                   # no state and no fix yet: unaided
    assert all(aided[3:]), aided                          # then aided on every channel
    assert aid["aided_epochs"] >= len(raw) - 3 and aid["aided_channel_epochs"] > 0
    assert aid["stale_epochs"] <= 2 and 0.05 < aid["mean_age_s"] < 0.5
    # the sheath: carrier lock kept by the aided loops at 30 dB (C/N0 ~ 15-20 dB-Hz at the hold)
    # is not asserted here (unit tests hold the thresholds); the receiver fixes again after it
    after = [m for m in raw if 16.0 <= m.header.stamp.sec <= DURATION_S]
    cp = [sum(bool(f & 2) for f in m.tracking_flags) / len(m.tracking_flags) for m in after]
    print(f"fraction of channels in carrier lock after the sheath (16-20 s): {np.round(cp, 2)}")
    # seen: 100 % of the channels in carrier lock at some epoch from 16 s; single epochs 38-100 % (the
    # boost's jerk on a 0.12-0.19 s old state: the true residual left the 3 sigma bound on 29-49 of
    # 152 channel-epochs)
    assert max(cp) >= 0.75
    assert any(sum(bool(x) for x in m.locked) >= 4 for m in after)
    summary = summarize(errors(states_from_msgs(nav), states_from_msgs(run["truth"])), 5.0)
    print(f"fusion position RMS 3D {summary['pos_enu_m']['rms_3d']:.2f} m")
    assert summary["pos_enu_m"]["rms_3d"] < 50.0
