"""Throughput of a reproduction as a campaign: the same seeds on a 1-worker
and a 2-worker LocalCluster, each as its own process (the command the user
types, start-up included), runs per minute and their ratio, with the load
average before and after (figures, not pass/fail).

    python benchmarks/repro_scaling.py [--repro seed003|seed004] [--seeds 20] [--short] [--scheduler ADDR]

``--scheduler`` runs the same command against an existing cluster instead
(nothing else changes: the commands take ``--scheduler`` as they take
``--workers``). The outputs of the two runs are compared (their JSON tables,
times left out).
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

CMDS = {"seed003": ("hyper_nav_repro.seed003.reproduce", "table3.json"),
        "seed004": ("hyper_nav_repro.seed004.reproduce", "seed004_tables.json")}


def _figures(x):
    if isinstance(x, dict):
        return {k: _figures(v) for k, v in x.items() if not any(w in k for w in ("wall", "time_s", "cpu"))}
    if isinstance(x, list):
        return [_figures(v) for v in x]
    return x


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repro", choices=sorted(CMDS), default="seed003")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--short", action="store_true", help="the reproduction's short mode (seconds per seed)")
    ap.add_argument("--scheduler", default=None)
    ap.add_argument("--extra", default="", help="more arguments for the reproduction command")
    a = ap.parse_args(argv)
    module, table = CMDS[a.repro]
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="hyper_nav_repro_scaling_"))
    rates, tables = {}, {}
    targets = [("scheduler", ["--scheduler", a.scheduler])] if a.scheduler else \
        [(w, ["--workers", str(w)]) for w in (1, 2)]
    print(f"{a.repro}: {a.seeds} seeds{' (short mode)' if a.short else ''}; {os.cpu_count()} cores; "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    for name, opt in targets:
        out = tmp / str(name)
        cmd = [sys.executable, "-m", module, "--seeds", str(a.seeds), "--out", str(out), *opt,
               *(["--short"] if a.short else []), *a.extra.split()]
        t0 = time.monotonic()
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        wall = time.monotonic() - t0
        if p.returncode != 0:
            print(p.stdout[-3000:])
            return 1
        rates[name] = 60.0 * a.seeds / wall
        tables[name] = _figures(json.loads((out / table).read_text()))
        print(f"workers {name}: {wall:.1f} s whole process, {rates[name]:.2f} seeds/min; load {os.getloadavg()[0]:.1f}",
              flush=True)
    if len(rates) == 2:
        print(f"throughput 2 workers / 1 worker: {rates[2] / rates[1]:.2f}; tables identical: {tables[1] == tables[2]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
