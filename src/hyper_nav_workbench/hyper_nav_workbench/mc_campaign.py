"""mc_campaign: a Monte Carlo campaign of a scenario on dask.distributed.

    ros2run hyper_nav_workbench mc_campaign --scenario default --runs 50 --out mc/default
    ros2run hyper_nav_workbench mc_campaign --scenario default --runs 50 --workers 2        # LocalCluster size
    ros2run hyper_nav_workbench mc_campaign --scenario default --runs 500 --scheduler tcp://10.0.0.5:8786

Each run draws sensor noise, true biases and initial errors from the
scenario's own distributions (``core/montecarlo.py``; ``--draw`` chooses
which) and flies the fusion core over the scenario with its declared
sources (``core/mc_sources.py``: loosely or tightly coupled GNSS, barometer,
and aiding nodes' outputs through the nodes' own logic in the loop, e.g.
geomagnetic map matching). By default a ``LocalCluster`` on this machine
(one single-threaded worker process per core, bound to 127.0.0.1, no
dashboard); ``--scheduler`` uses an existing cluster, nothing else changes.
The numbers depend on the scenario and the run indices only, not on the
number or kind of workers.

Writes ``campaign.json`` (per-run metrics; per epoch ANEES and ANIS with
their 95 % chi-square bands, RMS, 50th and 95th percentiles of the 3D
errors, the filter's RMS sigma), ``mc_errors.png`` and
``mc_consistency.png``; prints progress (runs done, runs per minute, ETA)
and a closing summary.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys

import numpy as np

from hyper_nav_workbench.core import montecarlo


def campaign(data: dict, runs: int, draws=montecarlo.DRAWS, grid_hz: float = 1.0, workers: int | None = None,
             scheduler: str | None = None, first_run: int = 0, progress: bool = True,
             keep_runs: bool = False, max_workers: int | None = None, out_dir=None) -> dict:
    """Run ``runs`` Monte Carlo runs through the campaign engine
    (``hyper_nav_workbench.campaign``: dask, local cluster or ``scheduler``) and
    aggregate them (see the module docstring). ``max_workers`` restricts the
    tasks to that many of the cluster's workers (an existing cluster shared
    with other work); ``out_dir``: one JSON per run (its metrics)."""
    from hyper_nav_workbench import campaign as engine
    skip = float((data.get("report") or {}).get("skip_s", 0.0))
    jobs = [(data, k, tuple(draws), grid_hz) for k in range(first_run, first_run + runs)]
    res = engine.run("mc_campaign", _run_one, jobs, keys=[f"run{k:04d}" for k in range(first_run, first_run + runs)],
                     opts=engine.Options(workers, scheduler, max_workers), out_dir=out_dir,
                     to_json=lambda r: montecarlo.run_metrics(r, skip), warm_up=WARM_UP, progress=progress)
    results = res.results
    cpu = float(sum(r["cpu_s"] for r in results))
    out = {"scenario": data["name"], "runs": runs, "draws": list(draws), "workers": res.workers,
           "wall_s": res.wall_s, "runs_per_min": res.runs_per_min, "cpu_s_per_run": cpu / runs,
           "cores_used": cpu / res.wall_s,      # < workers when the machine is shared with other work
           "per_run": [montecarlo.run_metrics(r, skip) for r in results], "stats": montecarlo.aggregate(results, skip)}
    if keep_runs:
        out["results"] = results
    return out


WARM_UP = ("hyper_nav_workbench.offline_fly", "hyper_nav_sim.core.boost_glide", "hyper_nav_sim.core.simulate")


def _run_one(job) -> dict:
    return montecarlo.run_one(*job)


def plot(result: dict, out_dir: pathlib.Path) -> list[pathlib.Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    s = result["stats"]
    t = np.asarray(s["t_s"])
    units = {"pos": "m", "vel": "m/s", "att": "deg"}
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    for ax, b in zip(axes, ("pos", "vel", "att")):
        ax.fill_between(t, np.asarray(s["p50_3d"][b]), np.asarray(s["p95_3d"][b]), color="tab:blue", alpha=0.2,
                        label="50th-95th percentile")
        ax.plot(t, s["rms_3d"][b], color="k", lw=1.0, label="RMS over runs")
        ax.plot(t, s["sigma_3d"][b], color="tab:red", lw=1.0, ls="--", label="filter's RMS sigma (3D)")
        ax.set_yscale("log")
        ax.set_ylabel(f"{b} error 3D [{units[b]}]")
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("sim time [s]")
    fig.suptitle(f"{result['scenario']}: {s['n_runs']} Monte Carlo runs, errors over time")
    fig.tight_layout()
    p1 = out_dir / "mc_errors.png"
    fig.savefig(p1, dpi=80)
    plt.close(fig)
    kinds = list(s["anis"])
    fig, axes = plt.subplots(3 + len(kinds), 1, figsize=(10, 3 + 2.2 * (3 + len(kinds))), sharex=True)
    lo, hi = s["anees_band"]
    for ax, b in zip(axes, ("pos", "vel", "att")):
        v = np.asarray(s["anees"][b])
        ax.plot(t, v, color="k", lw=1.0, label=f"ANEES {b} (3 dof)")
        ax.axhspan(lo, hi, color="tab:green", alpha=0.25, label=f"95 % band, {s['n_runs']} runs")
        ax.set_ylabel(f"ANEES {b}")
        ax.set_title(f"{b}: {100 * s['summary'][b]['share_in_band']:.0f} % of epochs in band, mean "
                     f"{s['summary'][b]['mean_anees']:.2f}", fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    ta = np.asarray(s["anis_t_s"])
    for ax, kind in zip(axes[3:], kinds):
        ax.plot(ta, s["anis"][kind], color="k", lw=1.0, label=f"ANIS {kind} ({s['anis_band'][kind]['dof']} dof)")
        ax.fill_between(ta, s["anis_band"][kind]["lo"], s["anis_band"][kind]["hi"], color="tab:green", alpha=0.25,
                        label="95 % band")
        ax.set_ylabel(f"ANIS {kind}")
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("sim time [s]")
    fig.suptitle(f"{result['scenario']}: consistency over {s['n_runs']} runs")
    fig.tight_layout()
    p2 = out_dir / "mc_consistency.png"
    fig.savefig(p2, dpi=80)
    plt.close(fig)
    return [p1, p2]


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def beside_paper(per_run: list[dict], sc) -> str:
    """Our largest error on any axis (E, N, U) over each run after
    report.skip_s (mean, spread and worst over the runs) beside the paper's
    per-axis bounds of the scenario's ``report.reference_*`` fields ('' when
    the scenario names no paper)."""
    source = sc["report.reference_source"]
    if not source:
        return ""
    lines = [f"largest |error| on any axis after {sc['report.skip_s']:g} s, per run; {len(per_run)} runs: "
             f"mean +- std [worst], beside {source}"]
    for b, field, unit in (("pos", "report.reference_pos_m", "m"), ("vel", "report.reference_vel_mps", "m/s"),
                           ("att", "report.reference_att_deg", "deg")):
        x = np.array([r[f"{b}_max_axis"] for r in per_run], float)
        ref = sc[field]
        lines.append(f"  {b:4s} {x.mean():9.4g} +- {x.std():8.3g} [{x.max():9.4g}] {unit:4s}"
                     + ("" if ref is None else f"  paper: < {ref:g} per axis"))
    return "\n".join(lines)


def main(argv=None) -> int:
    from hyper_nav_sim.core.scenario import ScenarioError, load_with_settings
    ap = argparse.ArgumentParser(prog="mc_campaign", description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="default", help="scenario name or YAML path")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", help="override a scenario field")
    ap.add_argument("--draw", default=",".join(montecarlo.DRAWS),
                    help=f"what each run draws (comma-separated subset of {','.join(montecarlo.DRAWS)})")
    ap.add_argument("--workers", type=int, default=None, help="LocalCluster worker processes (default: one per core)")
    ap.add_argument("--scheduler", help="address of an existing dask scheduler (tcp://host:port)")
    ap.add_argument("--max-workers", type=int, default=None, help="use at most this many of the cluster's workers")
    ap.add_argument("--grid-hz", type=float, default=1.0, help="epochs per second kept for the statistics")
    ap.add_argument("--out", default=None, help="output directory (default mc/<scenario>)")
    args = ap.parse_args(argv)
    draws = tuple(d for d in args.draw.split(",") if d)
    bad = [d for d in draws if d not in montecarlo.DRAWS]
    if bad or args.runs < 1:
        print(f"mc_campaign: error: --draw: unknown {bad} (known: {list(montecarlo.DRAWS)})" if bad else
              "mc_campaign: error: --runs must be >= 1", file=sys.stderr)
        return 2
    try:
        sc = load_with_settings(args.scenario, args.set)
    except ScenarioError as exc:
        print(f"mc_campaign: error: {exc}", file=sys.stderr)
        return 2
    out_dir = pathlib.Path(args.out or f"mc/{sc.name}")
    out_dir.mkdir(parents=True, exist_ok=True)
    where = args.scheduler or f"LocalCluster, {args.workers or os.cpu_count()} worker(s)"
    print(f"[mc_campaign] {sc.name}: {args.runs} runs of {sc['duration_s']} s, drawing {', '.join(draws)}; {where}",
          flush=True)
    result = campaign(sc.data, args.runs, draws, args.grid_hz, args.workers, args.scheduler,
                      max_workers=args.max_workers, out_dir=out_dir / "runs")
    (out_dir / "campaign.json").write_text(json.dumps(_jsonable(result), indent=1))
    pngs = plot(result, out_dir)
    s = result["stats"]
    print(f"{'':6s} {'RMS 3D':>10s} {'mean ANEES':>11s} {'in 95% band':>12s}   (band [{s['anees_band'][0]:.2f}, "
          f"{s['anees_band'][1]:.2f}] for {s['n_runs']} runs, 3 dof)")
    for b, unit in (("pos", "m"), ("vel", "m/s"), ("att", "deg")):
        m = s["summary"][b]
        print(f"{b:6s} {m['rms_3d']:10.4g} {m['mean_anees']:11.2f} {100 * m['share_in_band']:11.0f}%   [{unit}]")
    for kind, v in s["anis"].items():
        print(f"ANIS {kind}: mean {np.nanmean(v):.2f} (dof {s['anis_band'][kind]['dof']})")
    kinds = sorted({k for r in result["per_run"] for k in r["accepted"]})
    if kinds:
        print("updates accepted / gated per run (mean): " + ", ".join(
            f"{k} {np.mean([r['accepted'].get(k, 0) for r in result['per_run']]):.1f} / "
            f"{np.mean([r['gated'].get(k, 0) for r in result['per_run']]):.1f}" for k in kinds))
    verdict = run_verdicts(result["per_run"])
    result["verdict"] = verdict
    paper = beside_paper(result["per_run"], sc)
    if paper:
        print(paper)
        result["beside_paper"] = paper
        (out_dir / "campaign.json").write_text(json.dumps(_jsonable(result), indent=1))
    (out_dir / "campaign.json").write_text(json.dumps(_jsonable(result), indent=1))
    print(f"[mc_campaign] wrote {out_dir / 'campaign.json'}, " + ", ".join(p.name for p in pngs))
    for w in verdict["warnings"]:
        print(f"[mc_campaign] warning: {w}")
    for f in verdict["failures"]:
        print(f"[mc_campaign] FAIL: {f}")
    print(f"VERDICT: {verdict['verdict']}" + (f" ({len(verdict['failed_runs'])} of {len(result['per_run'])} runs "
                                              f"fail the per-source rules, core/verdict_rules.py)"
                                              if verdict["failures"] else " (every run passes the per-source rules)"))
    return 0 if verdict["verdict"] == "PASS" else 1


def run_verdicts(per_run: list[dict]) -> dict:
    """The per-source rules (``core.verdict_rules``) on every run: the
    campaign fails when any run does; each sentence names its run."""
    from hyper_nav_workbench.core import run_check, verdict_rules
    failures, warnings, failed = [], [], []
    for r in per_run:
        stats = {kd: verdict_rules.SourceStats(kd, int(r["accepted"].get(kd, 0)), int(r["gated"].get(kd, 0)),
                                               float(r.get("mean_nis_per_dof", {}).get(kd, float("nan"))),
                                               int(r.get("far", {}).get(kd, 0)),
                                               int(r.get("recoveries", {}).get(kd, 0)))
                 for kd in sorted(set(r["accepted"]) | set(r["gated"]))}
        out = run_check.Outcome()
        verdict_rules.check(stats, out)
        failures += [f"run {r['k']}: {f}" for f in out.failures]
        warnings += [f"run {r['k']}: {w}" for w in out.warnings]
        if out.failures:
            failed.append(r["k"])
    return {"verdict": "FAIL" if failures else "PASS", "failures": failures, "warnings": warnings,
            "failed_runs": failed}


if __name__ == "__main__":
    sys.exit(main())
