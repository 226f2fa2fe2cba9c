"""Reproduce seed 004 Tables 4-5 (Gao et al. 2023, section 3): horizontal and
vertical position and velocity error statistics (mean, standard deviation,
maximum) of the tightly coupled filter on the seed 004 flight, lock lost on
every satellite from 30 s, for the paper's cases (a) no lock loss, (b)
virtual compensation, (c) no compensation (corrupted observations reach the
filter) and (d) INS coasting, over several random seeds, in the realistic
and the perfect-model simulated worlds. Prints our numbers beside the
paper's, writes ``seed004_tables.json`` and the error curves (the paper's
Figs. 5-6) as PNGs.

    ros2run hyper_nav_repro repro_seed004 [--seeds 3] [--worlds realistic,perfect] [--out DIR] [--short]

Variants beside the paper's cases (case (b) is the fused-state source with
the paper's eq. 11 noise added, as the scenario says):

* ``b_alpha_beta``: vehicle position from an alpha-beta extrapolation of the
  receiver's fixes instead of the fused state (issue #8: measure both);
* ``b_noise_free``: (b) without eq. 10's D_noise draws (the information
  content of a virtual range: its innovation is then identically zero);
* ``b_consistent``: (b) with the fused state's own position sigma added to
  the virtual ranges' sigma;
* ``c_gated`` (on request, ``--variants``): (c) through our filter's
  chi-square gate (the paper's filter has none; ``c`` is flown without it):
  every corrupted epoch is gated and it is (d) exactly (measured).

Statistics over t >= the loss of lock (30 s), where the cases differ; the
paper does not say which interval its tables cover.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

import numpy as np

from hyper_nav_aiding.virtual_gnss.offline import prepare

from .cases import CASE_NAMES, run_case, statistics

# Seed 004 Table 4 (position, m) and Table 5 (velocity, m/s): mean, std, max
PAPER = {
    "a": {"pos_h_m": (7.821, 4.681, 22.356), "pos_v_m": (3.619, 2.781, 17.689),
          "vel_h_mps": (0.675, 0.151, 1.1728), "vel_v_mps": (0.518, 0.167, 0.817)},
    "b": {"pos_h_m": (10.690, 7.001, 41.757), "pos_v_m": (6.676, 5.539, 28.373),
          "vel_h_mps": (0.895, 0.232, 1.234), "vel_v_mps": (0.673, 0.271, 0.986)},
    "c": {"pos_h_m": (76.375, 40.052, 218.975), "pos_v_m": (21.830, 17.516, 87.161),
          "vel_h_mps": (3.765, 2.223, 10.431), "vel_v_mps": (1.578, 1.265, 5.731)},
}
# case -> (paper case, run_case arguments)
VARIANTS = {
    "a": ("a", {}),
    "b": ("b", {}),
    "b_alpha_beta": ("b", {"virtual": {"position_source": "alpha_beta"}}),
    "b_noise_free": ("b", {"virtual": {"add_noise": False}}),
    "b_consistent": ("b", {"virtual": {"consistent_covariance": True}}),
    "c": ("c", {"gate": False}),
    "c_gated": ("c", {}),
    "d": ("d", {}),
}
DEFAULT_VARIANTS = ("a", "b", "b_alpha_beta", "b_noise_free", "b_consistent", "c", "d")   # c_gated: on request
SHORT_DURATION_S, SHORT_LOSS_S = 16.0, 10.0      # --short (the test): loss from 10 s instead of 30 s
QUANTITIES = (("pos_h_m", "horizontal position [m]"), ("pos_v_m", "vertical position [m]"),
              ("vel_h_mps", "horizontal velocity [m/s]"), ("vel_v_mps", "vertical velocity [m/s]"))


def run_flight(job) -> dict:
    """One campaign run: one seed in one world, every variant. ``job``:
    (world, seed, variants, duration_s, overrides). {variant: (statistics, CaseResult)}."""
    world, seed, variants, duration_s, overrides = job
    fl = prepare(seed, world, duration_s, overrides=overrides)
    out = {}
    for v in variants:
        case, kw = VARIANTS[v]
        res = run_case(fl, case, **kw)
        st = statistics(res, fl.t_loss_s if np.isfinite(fl.t_loss_s) else 0.0)
        st["full_flight"] = statistics(res, 0.0)
        st["gate"] = {k: [int(x[0]), int(x[1])] for k, x in res.stats.items()}
        st["virtual_counters"] = res.counters
        out[v] = (st, res)
    return out


def run(seeds, worlds, variants, duration_s=None, overrides=None, log=print, opts=None, out_dir=None):
    """{world: {variant: {"per_seed": [stats...], "curves": CaseResult of the first seed}}}: every
    (world, seed) a run of the campaign engine (``hyper_nav_workbench.campaign``: dask, ``opts``)."""
    from hyper_nav_workbench import campaign
    jobs = [(world, seed, tuple(variants), duration_s, overrides) for world in worlds for seed in seeds]
    res = campaign.run("repro_seed004", run_flight, jobs, keys=[f"{w}_seed{s:03d}" for w, s, *_ in jobs],
                       opts=opts or campaign.Options(), out_dir=out_dir,
                       to_json=lambda r: {v: st for v, (st, _) in r.items()},
                       warm_up=("hyper_nav_repro.seed004.reproduce",))
    out = {world: {v: {"per_seed": []} for v in variants} for world in worlds}
    for (world, seed, *_), by_v in zip(jobs, res.results):
        for v in variants:
            st, case = by_v[v]
            out[world][v]["per_seed"].append(st)
            if "curves" not in out[world][v]:
                out[world][v]["curves"] = case
            log(f"  [{world}] seed {seed} {v:13s} {case.wall_s:5.0f} s: pos h {st['pos_h_m']['mean']:8.2f} "
                f"v {st['pos_v_m']['mean']:8.2f} m, NEES {st['nees_pos_mean']:.3g}")
    return out


def summary(per_seed: list) -> dict:
    """Mean and standard deviation over seeds of every statistic."""
    out = {}
    for q, _ in QUANTITIES:
        out[q] = {s: (float(np.mean([p[q][s] for p in per_seed])), float(np.std([p[q][s] for p in per_seed])))
                  for s in ("mean", "std", "max")}
    out["nees_pos_mean"] = (float(np.mean([p["nees_pos_mean"] for p in per_seed])),
                            float(np.std([p["nees_pos_mean"] for p in per_seed])))
    return out


def table(results, n_seeds) -> str:
    lines = []
    for world, by_v in results.items():
        lines.append(f"\n=== {world} world: mean / std / max of the error norm over the loss of lock, "
                     f"each as mean +- spread over {n_seeds} seed(s); paper's Tables 4-5 beside ===")
        for q, label in QUANTITIES:
            lines.append(f"{label:27s} {'ours mean':>17s} {'ours std':>15s} {'ours max':>17s}   paper mean/std/max")
            for v, d in by_v.items():
                s = summary(d["per_seed"])[q]
                paper = PAPER.get(VARIANTS[v][0], {}).get(q)
                ptxt = "  ".join(f"{x:.3f}" for x in paper) if paper is not None and v in PAPER else "-"
                lines.append(f"  {v:13s}{'':12s}" + "".join(f"{s[k][0]:10.3f} +-{s[k][1]:<7.3f}" for k in
                                                          ("mean", "std", "max")) + f"  {ptxt}")
        lines.append("position NEES (3 dof, mean over the loss of lock; consistent = 3):")
        for v, d in by_v.items():
            n = summary(d["per_seed"])["nees_pos_mean"]
            lines.append(f"  {v:13s} {n[0]:.3g} +- {n[1]:.2g}")
    return "\n".join(lines)


def plot(results, out_dir: pathlib.Path) -> list[pathlib.Path]:
    """Error curves of the first seed (the paper's Figs. 5-6) and the NEES, one PNG per world."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = []
    for world, by_v in results.items():
        fig, ax = plt.subplots(3, 2, figsize=(12, 10), sharex=True)
        for v, d in by_v.items():
            r = d["curves"]
            p, vel = r.pos_err_enu_m, r.vel_err_enu_mps
            ax[0, 0].plot(r.t_s, np.hypot(p[:, 0], p[:, 1]), label=v)
            ax[0, 1].plot(r.t_s, np.abs(p[:, 2]), label=v)
            ax[1, 0].plot(r.t_s, np.hypot(vel[:, 0], vel[:, 1]), label=v)
            ax[1, 1].plot(r.t_s, np.abs(vel[:, 2]), label=v)
            ax[2, 0].semilogy(r.t_s, np.maximum(r.nees_pos, 1e-3), label=v)
            ax[2, 1].semilogy(r.t_s, r.pos_sigma_m, label=v)
        for a, title in zip(ax.flat, ("horizontal position error [m]", "vertical position error [m]",
                                      "horizontal velocity error [m/s]", "vertical velocity error [m/s]",
                                      "position NEES (3 dof)", "filter position sigma sqrt(tr P) [m]")):
            a.set_title(title)
            a.grid(True, alpha=0.3)
        for a in ax[0]:
            a.set_yscale("symlog", linthresh=10.0)
        for a in ax[1]:
            a.set_yscale("symlog", linthresh=1.0)
        ax[0, 0].legend(fontsize=8)
        for a in ax[2]:
            a.set_xlabel("time [s]")
        fig.suptitle(f"seed 004 lock loss, {world} world (first seed)")
        fig.subplots_adjust(left=0.07, right=0.98, top=0.93, bottom=0.06, hspace=0.3, wspace=0.2)
        path = out_dir / f"seed004_errors_{world}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=None, help="number of random seeds (scenario seed 1..N; default 3, "
                    "1 with --short)")
    ap.add_argument("--worlds", default="realistic,perfect")
    ap.add_argument("--variants", default=",".join(DEFAULT_VARIANTS), help=f"any of {', '.join(VARIANTS)}")
    ap.add_argument("--out", default="seed004_tables")
    ap.add_argument("--short", action="store_true",
                    help="test mode: 16 s flight, lock lost from 10 s, IMU at 50 Hz, 1 seed (or --seeds), realistic world, "
                         "cases a-d")
    from hyper_nav_workbench import campaign
    campaign.add_arguments(ap)             # --workers, --scheduler, --max-workers: the (world, seed) runs on dask
    a = ap.parse_args(argv)
    worlds, variants, seeds, dur = a.worlds.split(","), a.variants.split(","), list(range(1, (a.seeds or 3) + 1)), None
    over = None
    if a.short:
        worlds, variants, seeds, dur = ["realistic"], ["a", "b", "c", "d"], list(range(1, (a.seeds or 1) + 1)), \
            SHORT_DURATION_S
        over = {"gnss.raw.lock.outages": [[SHORT_LOSS_S, 500.0]], "imu.rate_hz": 50.0}
    bad = [v for v in variants if v not in VARIANTS] + [w for w in worlds if w not in ("realistic", "perfect")]
    if bad:
        print(f"unknown variant/world {bad}; variants {list(VARIANTS)}, worlds realistic, perfect", file=sys.stderr)
        return 2
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"[repro_seed004] {len(seeds)} seed(s) x {len(worlds)} world(s) on {campaign.where(campaign.options(a))}",
          flush=True)
    results = run(seeds, worlds, variants, dur, over, opts=campaign.options(a), out_dir=out / "runs")
    print(table(results, len(seeds)))
    doc = {"paper": PAPER, "cases": {v: f"{VARIANTS[v][0]}: {CASE_NAMES[VARIANTS[v][0]]}" for v in variants},
           "seeds": seeds, "duration_s": dur or 500.0, "statistics_from_s": SHORT_LOSS_S if a.short else 30.0,
           "results": {w: {v: {"summary": summary(d["per_seed"]), "per_seed": d["per_seed"]}
                           for v, d in by_v.items()} for w, by_v in results.items()}}
    (out / "seed004_tables.json").write_text(json.dumps(doc, indent=1))
    pngs = plot(results, out)
    print(f"\nwrote {out / 'seed004_tables.json'} and {', '.join(str(p) for p in pngs)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
