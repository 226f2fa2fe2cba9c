"""The live node graph's throughput (issue 15): for the default scenario
(50 Hz IMU) and seed 001 at its native 500 Hz, the highest real-time factor
at which the fusion node loses nothing (received == published on every one
of its inputs, from the nodes' /diagnostics), and its CPU share there.
Only /diagnostics is recorded (the recorder is not what is measured)."""
from __future__ import annotations

import os
import time

from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.report import load_run
from scratch import scratch_dir

# label: (scenario, factors tried in turn, overrides)
CASES = {"default (50 Hz IMU)": ("default", (10.0, 20.0, 25.0, 30.0, 40.0), {}),
         # the same IMU stream with the solutions (4 messages each) at 10 Hz instead of 50 Hz
         "default, outputs at 10 Hz": ("default", (20.0, 30.0, 40.0, 60.0),
                                       {"filter.config.output_rate_hz": 10.0}),
         # the /clock cap off: /clock at 50 Hz of sim time whatever the factor (1000 msg/s at 20x)
         "default, /clock uncapped": ("default", (10.0, 20.0), {"graph.clock_max_wall_hz": 1.0e6}),
         "seed001 (500 Hz IMU, native)": ("seed001", (0.5, 1.0, 1.5, 2.0, 3.0, 4.0), {})}
WALL_S = 8.0        # flight length in wall seconds at each factor


def _cpu_s(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run_once(scenario: str, rtf: float, overrides: dict | None = None) -> dict:
    tmp = scratch_dir("live_")
    over = {"duration_s": WALL_S * rtf, "graph.real_time_factor": rtf, **(overrides or {})}
    with Graph(scenario, record=tmp / "bag", overrides=over, log_dir=tmp / "logs",
               node_params={"recorder": {"topics": ["/diagnostics"]}}) as g:
        truth, fusion = g.procs["truth"], g.procs["fusion"]
        cpu0, t0 = None, None
        while truth.poll() is None:
            if cpu0 is None and os.path.exists(f"/proc/{fusion.pid}/stat"):
                cpu0, t0 = _cpu_s(fusion.pid), time.monotonic()
            time.sleep(0.05)
        cpu = (_cpu_s(fusion.pid) - cpu0) / (time.monotonic() - t0)
        g.wait_until_done()
    run = load_run(tmp / "bag")
    diag = run["diagnostics"]
    fusion_d = diag.get("hyper_nav_filter: fusion", {})
    published = {k.split(" ", 1)[1].lstrip("/"): int(v) for d in diag.values() for k, v in d.items()
                 if k.startswith("published ")}
    lost = {}
    for key, v in fusion_d.items():
        if key.startswith("received ") and "(" not in key:
            topic = key.split(" ", 1)[1]
            if topic in published and int(v) != published[topic]:
                lost[topic] = (published[topic], int(v))
    return {"rtf": rtf, "lossless": not lost, "lost": lost, "fusion_cpu": cpu,
            "processed_imu": int(fusion_d.get("processed imu/data_raw", 0))}


def live_search(quick: bool = False) -> dict:
    out = {}
    print("== live graph: highest lossless real-time factor (fusion received == published) ==")
    for label, (scenario, factors, overrides) in CASES.items():
        best, rows = None, []
        for rtf in factors[:3] if quick else factors:
            r = run_once(scenario, rtf, overrides)
            rows.append(r)
            print(f"  {label:32s} x{rtf:<5g} {'lossless' if r['lossless'] else 'LOST ' + str(r['lost'])}; "
                  f"fusion CPU {100 * r['fusion_cpu']:.0f} % of a core")
            if not r["lossless"]:
                break
            best = r
        out[label] = {"highest_lossless_rtf": None if best is None else best["rtf"],
                      "fusion_cpu_at_best": None if best is None else best["fusion_cpu"], "runs": rows}
        print(f"  -> {label}: highest lossless factor "
              f"{'none' if best is None else best['rtf']}")
    return out


if __name__ == "__main__":
    live_search()
