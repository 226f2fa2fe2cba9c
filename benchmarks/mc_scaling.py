"""Monte Carlo campaign throughput on dask: runs per minute with 1 and 2
LocalCluster workers on this machine (figures, not pass/fail).

    python benchmarks/mc_scaling.py [--scenario default] [--runs 8] [--set duration_s=300]

Wall time counts from the cluster being up to the last result (worker
imports included, cluster start-up not); the speedup is 2-worker / 1-worker
runs per minute. On a machine shared with other jobs the speedup shows the
cores the campaign actually got.
"""
from __future__ import annotations

import argparse
import os
import time

import yaml

from hyper_nav_sim.core.scenario import apply_overrides, load_scenario
from scratch import scratch_dir
from hyper_nav_workbench.mc_campaign import campaign


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenario", default="default")
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--set", action="append", default=[])
    args = ap.parse_args()
    sc = load_scenario(args.scenario)
    over = {k: yaml.safe_load(v) for k, _, v in (s.partition("=") for s in args.set)}
    if over:
        sc = apply_overrides(sc, over, scratch_dir("scenario_"))
    print(f"{sc.name}: {args.runs} runs of {sc['duration_s']} s; {os.cpu_count()} cores; load "
          f"{os.getloadavg()[0]:.1f}")
    rates = {}
    for w in (1, 2):
        t0 = time.monotonic()
        r = campaign(sc.data, args.runs, workers=w)
        rates[w] = r["runs_per_min"]
        print(f"workers {w}: {r['runs_per_min']:.2f} runs/min ({r['wall_s']:.1f} s for {args.runs} runs, "
              f"{time.monotonic() - t0:.1f} s with cluster start-up); {r['cpu_s_per_run']:.1f} CPU s per run, "
              f"{r['cores_used']:.2f} cores used; pos RMS 3D "
              f"{r['stats']['summary']['pos']['rms_3d']:.3f} m, mean ANEES pos "
              f"{r['stats']['summary']['pos']['mean_anees']:.2f}")
    print(f"speedup 2 workers / 1 worker: {rates[2] / rates[1]:.2f} (load average now {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
