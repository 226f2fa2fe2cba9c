"""The recorder's own limits (issue 33): the highest total message rate it
records without loss on this machine, in messages/s and MB/s, and what it
does beyond it.

The real ``recorder`` executable records ``N_TOPICS`` topics of
``sensor_msgs/Imu`` (the graph's hot stream, 4 topics here) that this
process publishes as the graph's nodes do (reliable, KEEP_LAST
``graph.qos_depth`` = 2000), at a ladder of total rates, each step for
``STEP_S`` s of wall time with a fresh recorder and bag. Lossless = every
topic's bag count equals what was published. Beyond the limit the
subscription queues overflow; the recorder counts what it lost from the
writers' sequence numbers (``lost <topic>``, its status ERROR, the counts
printed when it closes the bag): the figure ``lost (counted)`` is its own
count beside ``published - recorded``, which must agree (never silent).

No clock gate here (no /clock): this is the recorder's throughput alone;
in a graph the gate slows the flight down to it instead of losing.

    python benchmarks/recorder_rate.py [--quick] [--json PATH]
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import re
import signal
import subprocess
import sys
import time

import rclpy
import yaml
from ament_index_python.packages import get_package_prefix
from rclpy.duration import Duration
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Imu

from hyper_nav_workbench.core.bag import read_bag
from scratch import scratch_dir

N_TOPICS = 4
RATES = (1000, 2000, 4000, 8000, 12000, 16000, 24000, 32000, 48000)     # total messages/s tried in turn
STEP_S = 5.0
DEPTH = 2000


def _recorder(bag: pathlib.Path, work: pathlib.Path, domain: int) -> subprocess.Popen:
    params = work / "recorder.params.yaml"
    topics = [f"/bench/imu{i}" for i in range(N_TOPICS)]
    params.write_text(yaml.safe_dump({"/**": {"ros__parameters": {
        "output": str(bag), "topics": topics, "qos_depth": DEPTH, "discovery_period_s": 0.1}}}))
    exe = pathlib.Path(get_package_prefix("hyper_nav_workbench")) / "lib" / "hyper_nav_workbench" / "recorder"
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED="1")
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return subprocess.Popen([str(exe), "--ros-args", "--params-file", str(params)], env=env,
                            stdout=(work / "recorder.log").open("w"), stderr=subprocess.STDOUT)


def _cpu_s(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def step(rate_hz: float, step_s: float, domain: int) -> dict:
    """Publish ``rate_hz`` messages/s in total over ``N_TOPICS`` topics for
    ``step_s`` s into a fresh recorder; what was published, recorded, lost."""
    work = scratch_dir("recorder_rate_")
    bag = work / "bag"
    rec = _recorder(bag, work, domain)
    ctx = rclpy.context.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node("recorder_rate_publisher", context=ctx)
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=DEPTH, reliability=ReliabilityPolicy.RELIABLE)
    pubs = [node.create_publisher(Imu, f"/bench/imu{i}", qos) for i in range(N_TOPICS)]
    try:
        deadline = time.monotonic() + 60.0
        while any(p.get_subscription_count() < 1 for p in pubs):
            if time.monotonic() > deadline or rec.poll() is not None:
                raise RuntimeError(f"recorder never subscribed:\n{(work / 'recorder.log').read_text()}")
            time.sleep(0.05)
        time.sleep(1.0)                           # one-sided matching: let the recorder's readers match too
        msg = Imu()
        msg.header.frame_id = "imu_link"
        size = len(serialize_message(msg))
        cpu0, t0 = _cpu_s(rec.pid), time.monotonic()
        sent, batch_s = 0, 0.005
        while (now := time.monotonic()) - t0 < step_s:
            due = int(rate_hz * (now - t0))
            while sent < due:
                msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(sent, 1000)
                pubs[sent % N_TOPICS].publish(msg)
                sent += 1
            time.sleep(batch_s)
        pub_s = time.monotonic() - t0
        for p in pubs:
            p.wait_for_all_acked(Duration(seconds=10.0))
        time.sleep(1.0)
        cpu = _cpu_s(rec.pid) - cpu0
    finally:
        rec.send_signal(signal.SIGINT)
        try:
            rec.wait(timeout=60)
        except subprocess.TimeoutExpired:
            rec.kill()
        node.destroy_node()
        ctx.try_shutdown()
    recorded = sum(1 for _ in read_bag(bag))
    log = (work / "recorder.log").read_text(errors="replace")
    lost_counted = sum(int(n) for n in re.findall(r"\((\d+) LOST\)", log))
    return {"rate_asked_msg_s": rate_hz, "rate_published_msg_s": round(sent / pub_s, 1), "published": sent,
            "recorded": recorded, "lost": sent - recorded, "lost_counted_by_recorder": lost_counted,
            "message_bytes": size, "mb_s": round(sent / pub_s * size / 1e6, 3),
            "recorder_cpu_fraction": round(cpu / pub_s, 2)}


def recorder_limits(quick: bool = False, domain: int | None = None) -> dict:
    """Run the ladder (stop two steps after the first loss); the lossless figure."""
    domain = domain if domain is not None else int(os.environ.get("ROS_DOMAIN_ID", "0")) or 42
    rows, losses = [], 0
    for rate in RATES:
        r = step(rate, 2.0 if quick else STEP_S, domain)
        rows.append(r)
        print(f"  asked {rate:6d} msg/s: published {r['rate_published_msg_s']:8.1f} msg/s "
              f"({r['mb_s']:.2f} MB/s), recorded {r['recorded']}/{r['published']}, lost {r['lost']} "
              f"(counted by the recorder: {r['lost_counted_by_recorder']}), recorder CPU "
              f"{100 * r['recorder_cpu_fraction']:.0f} %", flush=True)
        losses += r["lost"] > 0
        if losses >= 2:
            break
        if r["rate_published_msg_s"] < 0.9 * rate:      # this one publishing thread is the limit now
            break
    ok = [r for r in rows if r["lost"] == 0]
    best = max(ok, key=lambda r: r["rate_published_msg_s"]) if ok else None
    silent = [r for r in rows if r["lost"] != r["lost_counted_by_recorder"]]
    publisher_bound = not losses
    out = {"topics": N_TOPICS, "qos_depth": DEPTH, "steps": rows,
           "lossless_msg_s": best and best["rate_published_msg_s"], "lossless_mb_s": best and best["mb_s"],
           "silent_losses": len(silent), "publisher_bound": publisher_bound}
    print(f"recorder: lossless up to {out['lossless_msg_s']} msg/s ({out['lossless_mb_s']} MB/s) of "
          f"{rows[0]['message_bytes']}-byte messages on {N_TOPICS} topics"
          + ("; no loss at the highest rate this publishing process reached (a lower bound; the recorder's CPU "
             f"there: {100 * rows[-1]['recorder_cpu_fraction']:.0f} %)" if publisher_bound else
             "; beyond it the loss was " + ("counted by the recorder in every step" if not silent
                                            else f"NOT counted in {len(silent)} step(s)")), flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="2 s per step")
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args()
    out = recorder_limits(args.quick)
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    sys.path.insert(0, str(pathlib.Path(__file__).parent))
    main()
