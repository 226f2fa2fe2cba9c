"""Fault injection over DDS (issue #6): the graph survives, says what
happened on /diagnostics, and the report never passes a run that lost data.

Each graph run checks several faults whose signatures do not overlap:

* ``test_killed_nodes``: kill -9 of the magnetometer, GNSS, IMU and fusion
  nodes during one flight;
* ``test_bad_input_replayed``: one replayed bag with a NaN burst, duplicated
  and reversed IMU stamps, a 5 s IMU gap, a GNSS stream that stops and a
  truncated file;
* ``test_signals_stop_cleanly``: SIGTERM and SIGINT to run_graph; kill -9
  of run_graph itself;
* the unreadable (20-byte) and truncated bags through every command.

Each asserts the diagnostics seen, the report's verdict and reasons, the
exit code, and that nothing recorded was lost (published == recorded for
every topic whose publisher lived to report its final count).
"""
import os
import pathlib
import shutil
import signal
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from faults import RunGraph, alive, command, doctor_bag, report_json, statuses  # noqa: E402

pytestmark = pytest.mark.graph
REPO = pathlib.Path(__file__).resolve().parents[1]
SAMPLE = REPO / "bags" / "sample_short"
MON = "hyper_nav_sim: monitor: "


def _levels(timeline, name):
    return [e[1] for e in timeline.get(name, [])]


def _monitor_levels(collector) -> dict:
    """Latest level of each monitor verdict seen live on /diagnostics."""
    out = {}
    for arr in list(collector.messages["/diagnostics"]):
        for st in arr.status:
            if st.name.startswith(MON):
                out[st.name[len(MON):]] = st.level[0] if isinstance(st.level, bytes) else int(st.level)
    return out


def _fusion_published(collector) -> int:
    """Solutions the fusion node has published so far (its status on /diagnostics)."""
    n = 0
    for arr in list(collector.messages["/diagnostics"]):
        for st in arr.status:
            if st.name == "hyper_nav_filter: fusion":
                n = max(n, int({kv.key: kv.value for kv in st.values}.get("published nav/state", 0)))
    return n


def _sim_time(collector) -> float:
    """The truth node's latest sim time seen on /diagnostics."""
    t = -1.0
    for arr in list(collector.messages["/diagnostics"]):
        for st in arr.status:
            if st.name == "hyper_nav_sim: truth":
                t = max(t, float({kv.key: kv.value for kv in st.values}.get("sim_time_s") or -1.0))
    return t


def test_killed_nodes(tmp_path):
    """kill -9 of the magnetometer, GNSS, IMU and fusion nodes, 0.5 s apart,
    once the monitor has seen every node alive, the flight has flown 2 s and
    fusion has published, in a 24 s flight at 3x:
    run_graph keeps the graph flying to the end, the monitor reports each node
    dead (ERROR, live on /diagnostics and in the bag) and the streams they
    carried missing, the recorder keeps every message of the surviving
    publishers, the report fails naming every dead node with its exit status
    and the sim time of its last heartbeat, and run_graph exits 1."""
    from diagnostic_msgs.msg import DiagnosticArray
    from hyper_nav_workbench.testing import TopicCollector
    bag = tmp_path / "bag"
    killed = {"mag": "magnetometer", "gnss": "gnss", "imu": "imu", "fusion": "fusion"}
    with TopicCollector({"/diagnostics": DiagnosticArray}, domain_id=int(os.environ.get("ROS_DOMAIN_ID", 0))) as c:
        rg = RunGraph(tmp_path, "--set", "duration_s=24", "--set", "report.skip_s=5",
                      "--set", "monitor.heartbeat_timeout_s=3", "--record", str(bag), "--report")
        everyone = ["truth", "imu", "gnss", "magnetometer", "fusion", "recorder"]
        assert c.wait_for(lambda m: all(_monitor_levels(c).get(f"node {n}") == 0 for n in everyone)
                          and _sim_time(c) >= 2.0 and _fusion_published(c) > 0, 120), (_monitor_levels(c), rg.output())
        pids = rg.children()
        for node in killed:
            rg.kill(node)
            rg.sleep_until(__import__("time").monotonic() + 0.5)
        dead = lambda m: all(_monitor_levels(c).get(f"node {n}") == 2 for n in killed.values())  # noqa: E731
        assert c.wait_for(dead, 60), _monitor_levels(c)
        live = _monitor_levels(c)
        code = rg.wait()
    out = rg.stdout
    assert code == 1, rg.output()
    assert "Traceback" not in rg.stderr, rg.stderr
    for node in killed:
        assert f"[run_graph] node '{node}' died (killed by SIGKILL)" in out
    assert not alive(pids.values()), "node processes left behind"
    assert live["node truth"] == live["node recorder"] == 0                   # the survivors stay OK
    assert live["stream imu/data_raw"] == live["stream nav/state"] == 2       # critical streams: ERROR
    assert live["stream gnss/fix"] == live["stream imu/mag"] == 1             # aiding streams: WARN

    rep = report_json(bag)
    assert rep["verdict"] == "FAIL" and "VERDICT: FAIL" in out
    for ros_name in killed.values():
        assert any(f.startswith(f"nodes: '{ros_name}' died (killed by SIGKILL)") and "last heartbeat at t = " in f
                   for f in rep["failures"]), (ros_name, rep["failures"])
    tl = statuses(bag)
    for ros_name in killed.values():
        assert 2 in _levels(tl, f"{MON}node {ros_name}"), ros_name
    # the graph flew on: the truth's stream and the clock were recorded in full
    rows = rep["delivery"]
    assert rows["truth/state"]["published"] == rows["truth/state"]["recorded"] == 1201
    assert rows["clock"]["published"] == rows["clock"]["recorded"]
    for topic in ("imu/data_raw", "gnss/fix", "imu/mag", "nav/state"):      # dead publishers: lower bounds
        assert rows[topic]["recorded"] >= rows[topic]["published"] > 0, (topic, rows[topic])
    assert rep["epochs"]["missing"] > 0


def test_bad_input_replayed(tmp_path):
    """The committed 20 s bag with a NaN burst (10 IMU samples from 3.02 s), an
    IMU sample sent three times (5.0 s), a reversed pair (6.02 after 6.04), an
    IMU gap of 5 s (7-12 s), GNSS stopping at 14 s and the file cut at 90 %
    (IMU up to 19.1 s), replayed into a live fusion node by ``run_graph
    --replay``: fusion rejects and counts exactly the bad samples, bridges the
    gap and keeps going; the monitor reports the IMU missing during the gap (ERROR, then
    OK again) and GNSS missing from 14 s (WARN); the report fails for the
    rejected inputs, the bridged gap, the epochs the rejected samples leave
    out and the truncated input, and exits 1; everything the player published
    was recorded and received by fusion."""
    src = tmp_path / "in"
    made = doctor_bag(SAMPLE, src, nan_s=np.arange(151, 161) * 0.02, duplicate_s=[5.0], swap_s=[6.02],
                      imu_gap_s=(7.0, 12.0), gnss_stop_s=14.0, cut_fraction=0.9)
    assert (made["nan"], made["duplicates"], made["swapped"], made["gap"]) == (10, 2, 1, 250)
    assert made["imu_readable"] < made["imu"]                               # the cut loses the tail
    bag = tmp_path / "out"
    # statuses every 0.5 s of wall time = 2 s of sim time at 4x: the 5 s gap is seen between two of them.
    # Late events accepted up to 8 s: the fixes of the IMU gap (7-12 s, sent within 1.25 s of wall
    # time) may reach the fusion node after the IMU that ends it when the machine is loaded (DDS
    # keeps the order within a topic, not across topics); at the default 3 s, 12 of them were
    # stale in a fresh-clone run beside the unit lane (the recorder had them in order)
    rg = RunGraph(tmp_path, "--replay", str(src), "--record", str(bag), "--report",
                  "--set", "graph.real_time_factor=4", "--set", "report.skip_s=5",
                  "--set", "graph.diagnostics_period_s=0.5", "--set", "filter.config.reprocess_window_s=8")
    code = rg.wait()
    assert code == 1, rg.output()
    assert "Traceback" not in rg.stderr, rg.stderr
    rep = report_json(bag)
    fusion = rep["fusion_diagnostics"]
    assert int(fusion["rejected_imu_nan"]) == 10
    assert int(fusion["rejected_imu_duplicate"]) == 2 and int(fusion["rejected_imu_out_of_order"]) == 1
    assert int(fusion["imu_gaps"]) == 1 and float(fusion["imu_gap_total_s"]) == pytest.approx(5.02, abs=0.03)
    fails = "\n".join(rep["failures"])
    assert "inputs: fusion rejected input messages: imu_duplicate 2, imu_nan 10, imu_out_of_order 1" in fails
    assert "inputs: fusion bridged 1 IMU gap(s), 5.0" in fails
    assert "inputs: imu/data_raw: received by fusion" in fails                # received != processed (13 rejected)
    assert "bag: player replayed a truncated bag: " in fails and "cut short" in fails
    gaps = {(round(g["from_s"], 2), round(g["to_s"], 2)) for g in rep["epochs"]["gaps"]}
    assert (3.02, 3.2) in gaps or (3.04, 3.2) in gaps, gaps                  # the rejected samples' epochs
    assert rep["verdict"] == "FAIL"
    tl = statuses(bag)
    bridged = [e for e in tl["hyper_nav_filter: fusion"] if "1 IMU gap(s) bridged, last 7.00-12.02 s" in e[2]]
    assert bridged and bridged[0][1] == 1                                     # fusion says it: WARN
    gnss = [e for e in tl[f"{MON}stream gnss/fix"] if e[1] == 1]
    assert gnss and 13.5 <= float(gnss[0][3]["since_t_s"]) <= 18.0, gnss[:1]
    assert 1 in _levels(tl, "hyper_nav_sim: player")                          # WARN: truncated input
    rows = rep["delivery"]
    for topic in ("imu/data_raw", "gnss/fix", "gnss/vel", "truth/state", "nav/state"):
        assert rows[topic]["published"] == rows[topic]["recorded"] > 0, (topic, rows[topic])
    for topic in ("imu/data_raw", "gnss/fix"):
        assert rows[topic]["received_by_fusion"] == rows[topic]["published"], (topic, rows[topic])
    assert rows["imu/data_raw"]["published"] == made["imu_readable"]
    assert rows["imu/data_raw"]["processed_by_fusion"] == made["imu_readable"] - 13
    # the recorded run, cut short afterwards: the report says so and fails
    mcap = next(bag.glob("*.mcap"))
    mcap.write_bytes(mcap.read_bytes()[: int(mcap.stat().st_size * 0.7)])
    (bag / "metadata.yaml").unlink()
    p = subprocess.run([command("hyper_nav_workbench", "report"), str(bag)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 1 and f"FAIL: bag: truncated: {mcap}" in p.stdout, p.stdout + p.stderr


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signals_stop_cleanly(tmp_path, sig):
    """SIGTERM (a CI runner, ``timeout``) and SIGINT (Ctrl-C) alike: a one-line
    message, no traceback, no node left running, the bag closed with its
    metadata, the report of what was flown (FAIL: interrupted), exit 128+n."""
    bag = tmp_path / "bag"
    rg = RunGraph(tmp_path, "--set", "duration_s=60", "--nodes", "truth,imu", "--record", str(bag), "--report",
                  "--set", "report.skip_s=1")
    t0 = rg.wait_for_log(tmp_path / "bag_logs", "truth", "subscribers matched")
    pids = rg.children()
    rg.sleep_until(t0 + 1.5)
    rg.proc.send_signal(sig)
    code = rg.wait(timeout_s=90)
    name = signal.Signals(sig).name
    assert code == 128 + sig, rg.output()
    assert f"[run_graph] {name}: stopping the graph (recorder last)" in rg.stdout
    assert "Traceback" not in rg.stderr and "KeyboardInterrupt" not in rg.stderr, rg.stderr
    assert not alive(pids.values()), "node processes left behind"
    assert (bag / "metadata.yaml").is_file()
    rep = report_json(bag)
    assert rep["verdict"] == "FAIL"
    assert rep["failures"][0].startswith(f"run: interrupted by {name}")
    assert rep["delivery"]["imu/data_raw"]["published"] == rep["delivery"]["imu/data_raw"]["recorded"] > 0


def test_kill_9_of_run_graph_leaves_no_node_behind(tmp_path):
    """run_graph itself killed (kill -9: no handler runs): its nodes get
    SIGTERM from the kernel (parent-death signal) and stop; the recorder
    still drains and closes the bag with its metadata."""
    import time
    bag = tmp_path / "bag"
    rg = RunGraph(tmp_path, "--set", "duration_s=60", "--nodes", "truth,imu", "--record", str(bag))
    t0 = rg.wait_for_log(tmp_path / "bag_logs", "truth", "subscribers matched")
    pids = rg.children()
    rg.sleep_until(t0 + 1.0)
    rg.proc.kill()
    assert rg.wait(timeout_s=30) == -signal.SIGKILL
    deadline = time.monotonic() + 30.0
    while alive(pids.values()) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not alive(pids.values()), "node processes left behind"
    assert (bag / "metadata.yaml").is_file()
    from hyper_nav_workbench.core.bag import read_bag
    reader = read_bag(bag)
    assert not reader.truncated and sum(1 for r in reader if r.topic == "/imu/data_raw") > 0


def test_unreadable_and_truncated_bags(tmp_path, capsys):
    """A 20-byte bag: every command says why and exits 2, no traceback, no
    node left running. A truncated bag: replay_filter fails (exit 1) naming
    the file, and still scores what is readable. (report, replay_filter and
    run_graph are called in-process, as their console scripts do.)"""
    from hyper_nav_workbench.graph import main as run_graph
    from hyper_nav_workbench.replay_filter import main as replay_filter
    from hyper_nav_workbench.report import main as report
    tiny = tmp_path / "tiny"
    tiny.mkdir()
    (tiny / "tiny.mcap").write_bytes((SAMPLE / "sample_short.mcap").read_bytes()[:20])
    for name, fn, argv in (("report", report, [str(tiny)]), ("replay_filter", replay_filter, [str(tiny)]),
                           ("run_graph", run_graph, ["--replay", str(tiny)])):
        assert fn(argv) == 2, name
        err = capsys.readouterr().err
        assert f"{name}: error: " in err and "tiny.mcap" in err, (name, err)
    p = subprocess.run([command("hyper_nav_workbench", "player"), "--ros-args", "-p", f"bag:={tiny}"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
    assert "player: error: " in p.stderr and "no readable messages" in p.stderr and "tiny.mcap" in p.stderr
    cut = tmp_path / "cut"
    shutil.copytree(SAMPLE, cut)
    mcap = cut / "sample_short.mcap"
    mcap.write_bytes(mcap.read_bytes()[: int(mcap.stat().st_size * 0.6)])
    (cut / "metadata.yaml").unlink()
    assert replay_filter([str(cut), "--set", "report.skip_s=2"]) == 1
    out = capsys.readouterr().out
    assert f"FAIL: bag: truncated: {mcap}" in out
    assert "accuracy after t >= 2 s" in out and "VERDICT: FAIL" in out


def test_flight_across_180_deg_in_2022(tmp_path):
    """Due east from 179.95E (across 180 deg at t ~ 3 s), magnetometer date
    2022.5 (WMM-2020): every longitude on every topic in [-180, 180), the
    GNSS updates after the crossing accepted (none gated), the report passes
    with metre-level errors, exit 0."""
    from faults import nav_longitudes_deg
    from hyper_nav_filter.core import wmm
    from hyper_nav_workbench.core.bag import deserialize, read_bag
    bag = tmp_path / "bag"
    rg = RunGraph(tmp_path, "--set", "duration_s=16", "--set", "start.lon_deg=179.95",
                  "--set", "start.vel_enu_mps=[1700.0, 0.0, 0.0]", "--set", "magnetometer.epoch_decimal_year=2022.5",
                  "--set", "report.skip_s=5", "--record", str(bag), "--report")
    code = rg.wait()
    lons = nav_longitudes_deg(bag)
    for topic in ("truth/state", "gnss/fix", "nav/state", "nav/fix"):
        lon = lons[topic]
        assert np.all((lon >= -180.0) & (lon < 180.0)), (topic, lon.min(), lon.max())
        assert lon.max() > 179.95 - 1e-3 and lon.min() < -179.8, (topic, lon.min(), lon.max())   # crossed
    rep = report_json(bag)
    fusion = rep["fusion_diagnostics"]
    assert int(fusion["gnss_pos_accepted"]) >= 150 and int(fusion["gnss_pos_gated"]) == 0, fusion
    assert rep["summary"]["pos_enu_m"]["rms_3d"] < 5.0                      # not 4e7 m
    assert code == 0 and rep["verdict"] == "PASS", (rep["failures"], rg.output())
    mags = [deserialize(r.raw, r.msgtype) for r in read_bag(bag) if r.topic == "/imu/mag"]
    assert len(mags) == 160                                                  # 0.1 .. 16.0 s at 10 Hz
    b_nT = np.linalg.norm([[m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z] for m in mags], axis=1) * 1e9
    tr = [deserialize(r.raw, r.msgtype) for r in read_bag(bag) if r.topic == "/truth/state"][0]
    ref = np.linalg.norm(wmm.field_enu_nT(tr.lat_rad, tr.lon_rad, tr.alt_m, 2022.5))
    assert abs(b_nT[0] - ref) < 30.0, (b_nT[0], ref)                         # WMM-2020 at the start, 5 nT noise
