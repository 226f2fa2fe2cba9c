"""Latency of the current-time state over DDS (issue 35): IMU message
publication -> current-time ``nav/state`` published (and received), on
this machine.

For each case (loosely coupled: the default scenario; tightly coupled:
seed004_tight; IMU at 200 Hz and 1 kHz) a short run of the simulated graph
is recorded (``run_graph --record``, the sensors' own message code), then a
fusion node is started alone with that scenario's parameters
(``graph.fusion_parameters``) and this process publishes the recorded inputs
at real time from plain rclpy publishers (raw CDR re-published as rclpy
messages; reliable QoS), stamping the wall time just before each IMU
``publish``; a subscription in the same process takes ``nav/state`` and
pairs each state with its IMU sample by stamp. Printed: median, p99 and max
latency, states received of IMU samples published (nothing may be
dropped), and the fusion process's CPU share over the run (utime + stime of
/proc/<pid>/stat over wall time). The latency is to the state's publication:
the DDS writer's source timestamp of each ``nav/state`` sample (rmw message
info, the system clock of this machine), so it holds one DDS hop (this
process -> the fusion node) and the node's work; the latency to the
state's receipt here (two hops) is printed beside it.

Shared machine: 2 cores, other engineers' tests running; report what it
says about that.

    python benchmarks/current_latency.py [--duration 20] [--cases loose200,loose1000,tight200,tight1000]
        [--executors single,events] [--variants plain,realtime,floor]
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
ROS2RUN = str(ROOT / "tools" / "ros2run")
CASES = {"loose200": ("default", 200.0), "loose1000": ("default", 1000.0),
         "tight200": ("seed004_tight", 200.0), "tight1000": ("seed004_tight", 1000.0)}


def record(scenario: str, imu_hz: float, duration_s: float, out: pathlib.Path, domain: int) -> pathlib.Path:
    bag = out / "bag"
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain)}
    subprocess.run([ROS2RUN, "hyper_nav_workbench", "run_graph", "--scenario", scenario, "--set", f"duration_s={duration_s}",
                    "--set", f"imu.rate_hz={imu_hz}", "--record", str(bag)], check=True, env=env,
                   stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    return bag


def cpu_s(pid: int) -> float:
    """utime + stime of a process and its children so far (s)."""
    total = 0.0
    for p in [pid] + [int(c) for c in pathlib.Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]:
        try:
            f = pathlib.Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()
            total += (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")
        except (FileNotFoundError, IndexError):
            pass
    return total


RT_SETTINGS = {"realtime.priority": 80, "realtime.lock_memory": True, "realtime.cpu_dma_latency_us": 0}


def echo_node(executor: str) -> None:
    """The floor of the measurement: an rclpy node that republishes each
    ``imu/data_raw`` sample at once as an empty ``nav/state`` with its stamp
    (no filter, no conversion), spun as the fusion node is (``run_node``, the
    same executor); subscribes the other inputs the bench publishes and drops
    them."""
    from geometry_msgs.msg import TwistWithCovarianceStamped
    from rclpy.node import Node
    from sensor_msgs.msg import Imu, NavSatFix

    from hyper_nav_filter.ros_util import publisher_qos, run_node, subscriber_qos
    from hyper_nav_msgs.msg import GnssEphemeris, GnssMeasurements, NavState

    class Echo(Node):
        executor_kind = executor

        def __init__(self):
            super().__init__("latency_floor")
            pub = self.create_publisher(NavState, "nav/state", publisher_qos(2000))

            def on_imu(m):
                out = NavState()
                out.header.stamp = m.header.stamp
                pub.publish(out)
            self.create_subscription(Imu, "imu/data_raw", on_imu, subscriber_qos(True, 2000))
            for typ, topic in ((NavSatFix, "gnss/fix"), (TwistWithCovarianceStamped, "gnss/vel"),
                               (GnssMeasurements, "gnss/raw"), (GnssEphemeris, "gnss/ephemeris")):
                self.create_subscription(typ, topic, lambda m: None, subscriber_qos(True, 2000))
    run_node(Echo)


def measure(bag: pathlib.Path, domain: int, executor: str = "single", realtime: bool = False,
            floor: bool = False) -> dict:
    import rclpy
    from rclpy.serialization import deserialize_message

    from hyper_nav_filter.nodes.fusion_node import message_class
    from hyper_nav_filter.ros_util import latched_qos, publisher_qos
    from hyper_nav_msgs.msg import NavState
    from hyper_nav_workbench.core.bag import read_bag
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_workbench.graph import _NoAliasDumper, bag_scenario, fusion_parameters
    from hyper_nav_filter.sources import make_sources, parse_sources

    sc = load_scenario(bag_scenario(bag))
    params = fusion_parameters(sc)
    params.update({f"filter.{k}": v for k, v in sc.filter_config().as_dict().items()})
    params.pop("filter.layout", None)
    inputs = {}
    for src in make_sources(parse_sources(sc.filter_sources()), sc.filter_config()):
        for i in src.inputs():
            inputs["/" + i.topic.lstrip("/")] = (i.msg_type, i.latched)
    # the node's parameters for every source input are reliable (the bench's publishers are)
    params.update({k: "reliable" for k in params if k.endswith(".qos")})
    params["executor"] = executor
    if realtime:
        params.update(RT_SETTINGS)
    pfile = pathlib.Path(tempfile.mkdtemp()) / "fusion.yaml"
    pfile.write_text(yaml.dump({"fusion": {"ros__parameters": params}}, Dumper=_NoAliasDumper))
    recs = [(r.topic, r.msgtype, r.raw) for r in read_bag(bag) if r.topic in inputs]
    types = {t: message_class(m.replace("/msg/", "/msg/")) for t, (m, _) in inputs.items()}
    msgs = [(t, deserialize_message(raw, types[t])) for t, _, raw in recs]
    msgs.sort(key=lambda tm: (not inputs[tm[0]][1], tm[1].header.stamp.sec + tm[1].header.stamp.nanosec * 1e-9
                              if hasattr(tm[1], "header") else 0.0))
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain)}
    cmd = ([sys.executable, __file__, "--echo-node", executor] if floor else
           [ROS2RUN, "hyper_nav_filter", "fusion_node", "--ros-args", "--params-file", str(pfile)])
    if os.environ.get("LATENCY_PROFILE") and not floor:      # the fusion node under cProfile, stats to this file
        cmd = [sys.executable, "-m", "cProfile", "-o", os.environ["LATENCY_PROFILE"], "-m",
               "hyper_nav_filter.nodes.fusion_node", *cmd[3:]]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    ctx = rclpy.context.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node("latency_bench", context=ctx)
    pubs = {t: node.create_publisher(types[t], t, latched_qos(500) if inputs[t][1] else publisher_qos(2000))
            for t in inputs}
    got, lock = {}, threading.Lock()

    def on_state(m, info):
        t_recv = time.time_ns()
        with lock:
            # the state's publication: the DDS writer's source timestamp (the system clock, as time.time_ns)
            got[(m.header.stamp.sec, m.header.stamp.nanosec)] = (info["source_timestamp"], t_recv)
    node.create_subscription(NavState, "nav/state", on_state, publisher_qos(20000))
    from rclpy.executors import SingleThreadedExecutor
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    spin = threading.Thread(target=ex.spin, daemon=True)
    spin.start()
    imu_topic = next(t for t in inputs if t.endswith("imu/data_raw"))
    sent = {}
    try:
        deadline = time.monotonic() + 120.0
        while time.monotonic() < deadline and not all(p.get_subscription_count() for p in pubs.values()):
            time.sleep(0.2)
        while time.monotonic() < deadline and not node.count_publishers("nav/state"):
            time.sleep(0.2)
        time.sleep(2.0)
        # this process holds every message of the run: a full garbage collection here (tens of ms) held
        # the IMU back and released it in a burst the node then drained (a harness stall measured as the
        # node's latency): the collector is off while publishing, what exists now frozen
        gc.collect()
        gc.freeze()
        gc.disable()
        cpu0, w0 = cpu_s(proc.pid), time.perf_counter()
        t_first = None
        for topic, m in msgs:
            if hasattr(m, "header") and not inputs[topic][1]:
                t = m.header.stamp.sec + m.header.stamp.nanosec * 1e-9
                if t_first is None:
                    t_first = (t, time.perf_counter())
                wait = t_first[1] + (t - t_first[0]) - time.perf_counter()
                if wait > 0:
                    time.sleep(wait)
            if topic == imu_topic:
                sent[(m.header.stamp.sec, m.header.stamp.nanosec)] = time.time_ns()
            pubs[topic].publish(m)
        time.sleep(3.0)
        wall, cpu = time.perf_counter() - w0, cpu_s(proc.pid) - cpu0
        gc.enable()
        gc.unfreeze()
    finally:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            log, _ = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            log, _ = proc.communicate()
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
    with lock:
        pairs = np.array([(got[k][0] - t, got[k][1] - t) for k, t in sent.items() if k in got], float) * 1e-6
    lat, lat_recv = (pairs[:, 0], pairs[:, 1]) if len(pairs) else (np.array([]), np.array([]))
    if os.environ.get("LATENCY_DEBUG"):
        print(log[-4000:])
    if not len(lat):
        raise RuntimeError(f"no nav/state received; fusion log:\n{log[-3000:]}")
    return {"imu_published": len(sent), "states_received": int(sum(k in got for k in sent)),
            "median_ms": float(np.median(lat)), "p99_ms": float(np.percentile(lat, 99)), "max_ms": float(lat.max()),
            "received": {"median_ms": float(np.median(lat_recv)), "p99_ms": float(np.percentile(lat_recv, 99)),
                         "max_ms": float(lat_recv.max())},
            "fusion_cpu_share": cpu / wall, "scenario": sc.name, "imu_hz": float(sc["imu.rate_hz"])}


def in_process(bag: pathlib.Path) -> dict:
    """The fusion node's own share of the latency, without DDS: per IMU
    message of the bag (deserialized as rclpy messages), the source router
    (engine, output predictor, release) and the current-time state's
    conversion into NavState, Odometry, NavSatFix and TFMessage bytes, as
    ``fusion_node`` does (``cdr_template``); median, p99, max (ms)."""
    from nav_msgs.msg import Odometry
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import NavSatFix

    from tf2_msgs.msg import TFMessage

    from hyper_nav_filter.core.fusion import FusionEngine
    from hyper_nav_filter.cdr_template import CdrTemplate
    from hyper_nav_filter.nodes.fusion_node import tf_message, message_class
    from hyper_nav_filter.output import (OutputFrames, map_pose, navsatfix_fields, navstate_fields, odometry_fields,
                                         transform_fields)
    from hyper_nav_filter.sources.router import SourceRouter
    from hyper_nav_msgs.msg import NavState
    from hyper_nav_workbench.core.bag import read_bag
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_workbench.graph import bag_scenario
    sc = load_scenario(bag_scenario(bag))
    cfg = sc.filter_config()
    eng = FusionEngine(cfg, sc.filter_initial_state())
    router = SourceRouter(eng, sc.filter_sources())
    routes = {"/" + t: r for t, r in router.routes.items()}
    init = sc.filter_initial_state()
    frames = OutputFrames("map", "enu", "base_link", init.lat_rad, init.lon_rad, init.alt_m)
    recs = [(r.topic, deserialize_message(r.raw, message_class(r.msgtype))) for r in read_bag(bag) if r.topic in routes]
    recs.sort(key=lambda tm: tm[1].header.stamp.sec + tm[1].header.stamp.nanosec * 1e-9
              if hasattr(tm[1], "header") else -1.0)
    tpl = [CdrTemplate(NavState), CdrTemplate(Odometry), CdrTemplate(NavSatFix),
           CdrTemplate(TFMessage, tf_message, prefix="transforms.0.")]
    times = []
    gc.collect()
    gc.freeze()          # as run_node does; the messages held here are not the node's
    gc.disable()
    for topic, m in recs:
        for src, role in routes[topic]:
            imu = src.drives_time and role == "main"
            t0 = time.perf_counter()
            reason, _ = router.handle(src, role, m)
            if imu and reason is None:
                sol = eng.current
                tpl[0].fill(navstate_fields(sol, cfg.layout, frames, cfg.mechanization_frame))
                tpl[0].bytes()
                pose = map_pose(sol, frames)
                tpl[1].fill(odometry_fields(sol, cfg.layout, frames, pose))
                tpl[1].bytes()
                tpl[2].fill(navsatfix_fields(sol, cfg.layout, frames))
                tpl[2].bytes()
                tpl[3].fill(transform_fields(sol, frames, pose))
                tpl[3].bytes()
                times.append(time.perf_counter() - t0)
    gc.enable()
    gc.unfreeze()
    ms = np.array(times[len(times) // 20:]) * 1e3
    return {"median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max()),
            "samples": len(ms)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    ap.add_argument("--executors", default="single",
                    help="the fusion node's executor(s), comma-separated, each measured on the same recording: "
                         "single, events")
    ap.add_argument("--variants", default="plain",
                    help="comma-separated, each measured per executor: plain (the fusion node as configured), "
                         "realtime (with its real-time settings, hyper_nav_filter.realtime: SCHED_FIFO 80 for its "
                         "threads, memory locked, /dev/cpu_dma_latency held at 0; needs root or CAP_SYS_NICE), floor "
                         "(an echo node in place of the fusion node: rclpy and DDS alone, each IMU sample republished "
                         "at once as an empty nav/state)")
    ap.add_argument("--echo-node", metavar="EXECUTOR", help=argparse.SUPPRESS)
    ap.add_argument("--out", default="results/current_latency.json")
    a = ap.parse_args(argv)
    if a.echo_node:
        echo_node(a.echo_node)
        return 0
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for case in a.cases.split(","):
            scenario, hz = CASES[case]
            bag = record(scenario, hz, a.duration, pathlib.Path(tmp) / case, a.domain)
            ip = in_process(bag)
            print(f"{case:10s} in process (router + engine + predictor + message conversion, no DDS): median "
                  f"{ip['median_ms']:.3f} ms, p99 {ip['p99_ms']:.3f} ms, max {ip['max_ms']:.3f} ms", flush=True)
            kinds = {"plain": (False, False), "realtime": (True, False), "floor": (False, True)}
            variants = [(ex, *kinds[v]) for ex in a.executors.split(",") for v in a.variants.split(",")]
            for ex, rt, fl in variants:
                r = measure(bag, a.domain, ex, rt, fl)
                r["in_process"] = ip
                r["executor"] = ex
                r["realtime"] = RT_SETTINGS if rt else None
                r["node"] = "echo (floor: rclpy + DDS, no filter)" if fl else "fusion_node"
                with open("/proc/loadavg") as fh:
                    r["loadavg_1min"] = float(fh.read().split()[0])
                results[(case if ex == "single" else f"{case}_{ex}") + ("_rt" if rt else "") + ("_floor" if fl
                                                                                                else "")] = r
                rv = r["received"]
                print(f"{case:10s} {scenario} IMU {hz:g} Hz, executor {ex}{' real-time' if rt else ''}"
                      f"{' ECHO NODE (floor)' if fl else ''}: IMU "
                      f"published -> state published: median {r['median_ms']:.3f} ms, p99 {r['p99_ms']:.3f} ms, max "
                      f"{r['max_ms']:.3f} ms (-> received here: {rv['median_ms']:.3f} / {rv['p99_ms']:.3f} / "
                      f"{rv['max_ms']:.3f} ms); states {r['states_received']} of "
                      f"{r['imu_published']} IMU samples; fusion node CPU {100 * r['fusion_cpu_share']:.0f} % of one "
                      f"core (machine load average {r['loadavg_1min']:.1f} on 2 cores)", flush=True)
    out = pathlib.Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"args": vars(a), "results": results,
                               "note": "2-core machine shared with other engineers' test runs"}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    sys.exit(main())
