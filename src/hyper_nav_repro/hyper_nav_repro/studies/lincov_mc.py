"""LinCov against Monte Carlo of the real filter (issue 39).

On a scenario (the default flight; a blackout flight with ``--blackout``)
one LinCov pass and N Monte Carlo runs of the fusion engine
(``montecarlo.run_one``, on a local dask cluster with ``--workers``): per
axis and epoch, LinCov's 1-sigma beside the Monte Carlo RMS, with the Monte
Carlo's own 95 % sampling band; then, with ``--split``, one draw kind at a
time (initial errors / turn-on biases / noise) against LinCov's groups of
that kind. CPU of the LinCov pass vs the CPU the runs took (the sum of
their process times). Writes ``lincov_mc.json`` and ``lincov_mc.png``.

    study_lincov_mc --scenario default --runs 200 --workers 2
    study_lincov_mc --scenario default --blackout 120:240 --runs 200 --split
    study_lincov_mc --scenario default --trajectory-of guidance_glide --set duration_s=60

``--trajectory-of NAME`` flies a user-style trajectory: NAME's truth written
as a trajectory file (``trajectory_file.write_csv``, 10 Hz by default, as a
6-DOF tool would hand it over) and flown as a user's file
(``trajectory_file``) with the sensors and filter of ``--scenario``.
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib
import time

import numpy as np

from hyper_nav_workbench.core import lincov_check, lincov_setup
from hyper_nav_sim.core.scenario import load_with_settings

from .lincov_budget import parse_window


def plot(res, cmp, path, title) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(3, 3, figsize=(13, 9), sharex=True)
    t = np.asarray(cmp["t_s"])
    lo, hi = cmp["band"]
    for i, (b, unit, scale) in enumerate((("pos", "m", 1.0), ("vel", "m/s", 1.0), ("att", "deg", 180 / math.pi))):
        c = cmp["blocks"][b]
        lin, mc = np.asarray(c["lincov_sigma"]) * scale, np.asarray(c["mc"]) * scale
        for j, ax_name in enumerate("ENU"):
            ax = axes[i, j]
            ax.fill_between(t, lin[:, j] * lo, lin[:, j] * hi, color="C0", alpha=0.2,
                            label=f"LinCov x MC 95% band ({cmp['n_runs']} runs)")
            ax.plot(t, lin[:, j], "C0-", label="LinCov 1-sigma")
            ax.plot(t, mc[:, j], "k.", ms=3, label="Monte Carlo " + ("std" if cmp["about_mean"] else "RMS"))
            ax.set_ylabel(f"{b} {ax_name} ({unit})")
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def summary(cmp) -> dict:
    return {b: {"max_abs_rel_diff": c["max_abs_rel_diff"], "share_within_10pct": c["share_within_10pct"],
                "share_within_band": c["share_within_band"]} for b, c in cmp["blocks"].items()}


def user_trajectory(base: str, of: str, rate_hz: float, out: pathlib.Path) -> pathlib.Path:
    """Scenario ``base`` flying scenario ``of``'s truth from a trajectory
    file written at ``rate_hz`` (absolute path: Monte Carlo workers read it
    from a scenario of their own); returns the scenario file's path."""
    import yaml

    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_sim.core.trajectory_file import write_csv
    src = load_scenario(of)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = (out / f"{src.name}_trajectory.csv").resolve()
    write_csv(csv_path, src.trajectory(), np.arange(0.0, float(src["duration_s"]) + 1e-9, 1.0 / rate_hz))
    base_data = load_scenario(base).data
    data = {k: v for k, v in base_data.items() if k not in ("start", "maneuvers", "flight", "trajectory_file")}
    data["name"] = f"{base_data['name']}_on_{src.name}_file"
    data["duration_s"] = min(float(base_data["duration_s"]), float(src["duration_s"]))
    data["trajectory_file"] = {"path": str(csv_path)}
    path = out / f"{data['name']}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="default")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE")
    ap.add_argument("--blackout", action="append", type=parse_window, default=[], metavar="T0:T1")
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--workers", type=int, default=0, help="dask worker processes (0: in this process)")
    ap.add_argument("--split", action="store_true", help="also one draw kind at a time (initial, biases, noise)")
    ap.add_argument("--skip-s", type=float, default=1.0, help="epochs before this are not scored")
    ap.add_argument("--trajectory-of", metavar="NAME",
                    help="fly scenario NAME's truth as a user's trajectory file (module doc)")
    ap.add_argument("--trajectory-hz", type=float, default=10.0, help="the file's rate (Hz)")
    ap.add_argument("--out", default="results/lincov_mc")
    a = ap.parse_args(argv)
    settings = list(a.set)
    if a.blackout:
        settings.append("gnss.outages_s=" + json.dumps([list(w) for w in a.blackout]))
    scenario = a.scenario
    if a.trajectory_of:
        scenario = str(user_trajectory(a.scenario, a.trajectory_of, a.trajectory_hz, pathlib.Path(a.out)))
    sc = load_with_settings(scenario, settings)
    out = pathlib.Path(a.out) / (sc.name + ("_blackout" if a.blackout else ""))
    out.mkdir(parents=True, exist_ok=True)
    res = lincov_setup.build(sc).run(record_every=1)
    print(f"LinCov pass: {res.cpu_s:.2f} s CPU ({len(res.t_s) - 1} steps, {res.n_updates} updates)")
    doc = {"what": "LinCov (simulated world's error models) vs Monte Carlo of the fusion engine on simulated sensors",
           "scenario": sc.name, "settings": settings, "lincov_cpu_s": res.cpu_s, "cases": {}}
    cases = [("all", ("noise", "biases", "initial"), None, False)]
    if a.split:
        cfg = sc.filter_config()
        for d in ("initial", "biases", "noise"):
            cases.append((d, (d,), lincov_check.groups_of_draw(d, res.groups, cfg.state_blocks), True))
    for name, draws, groups, about_mean in cases:
        w0 = time.perf_counter()
        runs = lincov_check.run_mc(sc.data, a.runs, draws, workers=a.workers)
        wall = time.perf_counter() - w0
        mc_cpu = float(sum(r["cpu_s"] for r in runs))
        cmp = lincov_check.compare(res, runs, groups, about_mean, skip_s=a.skip_s,
                                   end_s=float(sc["duration_s"]) - 1.0)   # the run's last epoch: see the test
        s = summary(cmp)
        doc["cases"][name] = {"draws": list(draws), "groups": groups, "mc_cpu_s": mc_cpu, "mc_wall_s": wall,
                              "cpu_ratio_mc_over_lincov": mc_cpu / max(res.cpu_s, 1e-9), "summary": s, **cmp}
        lo, hi = cmp["band"]
        print(f"\n[{name}] {a.runs} runs, draws {list(draws)}: MC {mc_cpu:.1f} s CPU = "
              f"{mc_cpu / max(res.cpu_s, 1e-9):.0f} x the LinCov pass; MC sampling band (95 %) of "
              f"{'std' if about_mean else 'RMS'}/sigma: [{lo:.3f}, {hi:.3f}]")
        for b, v in s.items():
            print(f"   {b}: max |MC/LinCov - 1| = {v['max_abs_rel_diff']:.3f}; epochs x axes within 10 %: "
                  f"{100 * v['share_within_10pct']:.1f} %, within the MC band: {100 * v['share_within_band']:.1f} %")
        plot(res, cmp, out / f"lincov_mc_{name}.png",
             f"{sc.name}: LinCov (simulated world's models) vs Monte Carlo of the filter, {a.runs} runs, draws "
             f"{list(draws)}; shaded: the MC's 95 % sampling band")
    (out / "lincov_mc.json").write_text(json.dumps(doc, indent=1))
    print(f"\nwrote {out / 'lincov_mc.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
