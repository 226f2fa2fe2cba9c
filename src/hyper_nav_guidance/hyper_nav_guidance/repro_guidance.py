"""repro_guidance (issue 36): what navigation costs at the target.

The guidance_glide flight (30 km / 3000 m/s to a point 300 km down-range,
40 km cross-range, 20 km lower) steered by the glide guidance law in the
offline closed loop (``closed_loop``: the cores of the live graph), over
seeds (IMU and GNSS noise draws; the flight and law are deterministic):

  truth                 guidance on the exact truth, commands applied 0.1 s after the state (the truth-fed
                        loop; the latency of the current-time stream too)
  truth_1.1s            the same with the 1.1 s apply delay the delayed stream needs (latency alone)
  nav_<stream>          on the fusion engine's navigation stream, GNSS throughout
  blackout_60s_<stream> the same with a 60 s GNSS blackout (40-100 s, ends 13 s before the target)
  ins_after_50s_<stream> GNSS lost from 50 s on: INS alone for the last ~63 s, through the terminal phase

Streams (``--stream``, default ``both``): ``delayed``, the 1 s delayed
solution (``nav/delayed/state``), commands applied 1.1 s after its stamp
(output_delay_s + one guidance period); ``current``, the engine's
current-time state (issue 35, ``nav/state``: the state at the newest IMU
sample, latency zero in stamp), commands applied 0.1 s after it (one
guidance period: the command for stamp t applies from the next guidance
step, as in the truth-fed loop, which is therefore its same-latency
reference). Per case: miss distance (mean, spread),
down-/cross-range error and navigation error (3-D, at the last navigation
stamp used) at the target, and the commands' RMS difference from the
truth-fed loop's at the same stamps. Data: simulated world (white-noise
GNSS fixes of ``gnss_model``, the scenario's IMU error model), the filter
model of the scenario; with ``--scenario guidance_glide_realistic`` the
realistic world: the raw-GNSS receiver (``gnss.raw``) and its least-squares
fixes, the blackouts as its own loss of lock (``FlownRaw``).

    ros2run hyper_nav_guidance repro_guidance --out results/guidance [--seeds 10] [--stream both|delayed|current] [--short]
    ros2run hyper_nav_guidance repro_guidance --scenario guidance_glide_realistic --out results/guidance_realistic
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib
import time

import numpy as np

from hyper_nav_sim.core.scenario import load_scenario

from .closed_loop import fly_on_navigation, fly_on_truth, with_changes

DELAYED_APPLY_S = 1.1          # > the filter's output_delay_s (1 s) + one guidance period
CURRENT_APPLY_S = 0.1          # the current-time stream: latency 0 in stamp, + one guidance period
APPLY_S = {"delayed": DELAYED_APPLY_S, "current": CURRENT_APPLY_S}
OUTAGES = {"nav": (), "blackout_60s": ((40.0, 100.0),), "ins_after_50s": ((50.0, math.inf),)}


def cases(stream: str):
    """name -> (kind, stream, scenario changes, GNSS outages); ``stream``: delayed, current or both."""
    streams = ("delayed", "current") if stream == "both" else (stream,)
    out = {"truth": ("truth", None, {}, ())}
    if "delayed" in streams:
        out["truth_1.1s"] = ("truth", None, {"guidance.apply_delay_s": DELAYED_APPLY_S}, ())
    for case, outages in OUTAGES.items():
        for st in streams:
            out[f"{case}_{st}"] = ("nav", st, {"guidance.apply_delay_s": APPLY_S[st]}, outages)
    return out


def command_difference(cmds, ref):
    """RMS over common stamps of (sigma deg, c_l) differences."""
    r = {round(c[0], 6): c for c in ref}
    d = np.array([(math.degrees(c[1] - r[k][1]), c[2] - r[k][2]) for c in cmds
                  if (k := round(c[0], 6)) in r])
    if len(d) == 0:
        return {"sigma_rms_deg": float("nan"), "c_l_rms": float("nan"), "n": 0}
    return {"sigma_rms_deg": float(np.sqrt(np.mean(d[:, 0] ** 2))), "c_l_rms": float(np.sqrt(np.mean(d[:, 1] ** 2))),
            "n": int(len(d))}


def run(out: pathlib.Path, seeds: int, stream: str, scenario: str = "guidance_glide") -> dict:
    base = load_scenario(scenario)
    out.mkdir(parents=True, exist_ok=True)
    rows, tracks = {}, {}
    ref = None
    for name, (kind, st, changes, outages) in cases(stream).items():
        rows[name] = []
        for s in range(seeds if kind == "nav" else 1):        # the truth loops have no noise: one run
            sc = with_changes(base, {**changes, "seed": int(base["seed"]) + s})
            t0 = time.perf_counter()
            r = fly_on_truth(sc) if kind == "truth" else fly_on_navigation(sc, st, outages)
            if name == "truth":
                ref = r.commands
            row = {"seed": int(sc["seed"]), **{k: float(v) for k, v in r.miss.items()},
                   "nav_error_end_m": float(r.nav_error_end_m), "t_end_s": float(r.t_end_s),
                   "commands": len(r.commands), "refused": r.refused,
                   "command_diff": command_difference(r.commands, ref), "wall_s": time.perf_counter() - t0}
            rows[name].append(row)
            print(f"{name:22s} seed {row['seed']:3d}  miss {row['miss_m']:8.2f} m  down {row['down_range_m']:8.2f}"
                  f"  cross {row['cross_range_m']:7.2f}  nav err {row['nav_error_end_m']:6.2f} m  "
                  f"d sigma {row['command_diff']['sigma_rms_deg']:.3f} deg  ({row['wall_s']:.0f} s)", flush=True)
            if s == 0:
                t = np.linspace(0.0, r.t_end_s, 400)
                tr = r.flight.truth(t)
                tracks[name] = {"t": t, "lat": tr.lat_rad, "lon": tr.lon_rad, "alt": tr.alt_m,
                                "cmd": np.array(r.commands)}
    summary = {}
    for name, rs in rows.items():
        m = np.array([r["miss_m"] for r in rs])
        summary[name] = {"runs": len(rs), "miss_mean_m": float(m.mean()), "miss_std_m": float(m.std()),
                         "miss_max_m": float(m.max()),
                         "down_range_mean_m": float(np.mean([r["down_range_m"] for r in rs])),
                         "cross_range_mean_m": float(np.mean([r["cross_range_m"] for r in rs])),
                         "nav_error_end_mean_m": float(np.mean([r["nav_error_end_m"] for r in rs])),
                         "sigma_diff_rms_deg": float(np.mean([r["command_diff"]["sigma_rms_deg"] for r in rs])),
                         "c_l_diff_rms": float(np.mean([r["command_diff"]["c_l_rms"] for r in rs]))}
        if name != "truth":
            summary[name]["miss_ratio_to_truth"] = summary[name]["miss_mean_m"] / max(summary["truth"]["miss_mean_m"],
                                                                                      1e-9)
    result = {"scenario": scenario, "stream": stream, "seeds": seeds, "summary": summary, "runs": rows,
              "data": _data_note(base),
              "apply_delay_s": {"truth": 0.1, "truth_1.1s": DELAYED_APPLY_S, **APPLY_S},
              "pending": [] if stream == "both" else [f"only the {stream} stream was run (--stream both for both)"]}
    (out / "repro_guidance.json").write_text(json.dumps(result, indent=1, default=float))
    _plots(out, tracks, summary, base)
    print(f"\n{'case':22s} {'runs':>4s} {'miss mean':>10s} {'spread':>8s} {'down':>8s} {'cross':>8s} "
          f"{'nav err':>8s} {'dsigma':>7s} {'x truth':>8s}")
    for name, s in summary.items():
        print(f"{name:22s} {s['runs']:4d} {s['miss_mean_m']:10.2f} {s['miss_std_m']:8.2f} "
              f"{s['down_range_mean_m']:8.2f} {s['cross_range_mean_m']:8.2f} {s['nav_error_end_mean_m']:8.2f} "
              f"{s['sigma_diff_rms_deg']:7.3f} {s.get('miss_ratio_to_truth', 1.0):8.1f}")
    return result


def _plots(out, tracks, summary, sc):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from hyper_nav_sim.core.guidance_config import GuidanceConfig
    cfg = GuidanceConfig.from_config(sc.data["guidance"])
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
    for name, tr in tracks.items():
        ax[0].plot(np.degrees(tr["lon"]), np.degrees(tr["lat"]), label=name)
        ax[1].plot(tr["t"], tr["alt"] / 1e3, label=name)
    ax[0].plot(math.degrees(cfg.target_lon_rad), math.degrees(cfg.target_lat_rad), "k*", ms=12, label="target")
    ax[0].set_xlabel("longitude (deg)"), ax[0].set_ylabel("latitude (deg)"), ax[0].legend(fontsize=8)
    ax[1].set_xlabel("t (s)"), ax[1].set_ylabel("altitude (km)")
    ax[0].set_title("ground tracks, first seed (simulated world)")
    ax[1].set_title("altitude")
    fig.tight_layout()
    fig.savefig(out / "tracks.png", dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    names = list(summary)
    ax.bar(names, [summary[n]["miss_mean_m"] for n in names], yerr=[summary[n]["miss_std_m"] for n in names],
           capsize=4)
    ax.set_ylabel("miss distance at the target altitude (m)")
    ax.set_title("miss distance by case: mean and spread over seeds (guidance_glide, simulated world)")
    fig.autofmt_xdate()
    fig.tight_layout()
    fig.savefig(out / "miss.png", dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for name, tr in tracks.items():
        c = tr["cmd"]
        if len(c):
            ax[0].plot(c[:, 0], np.degrees(c[:, 1]), label=name, lw=0.8)
            ax[1].plot(c[:, 0], c[:, 2], label=name, lw=0.8)
    ax[0].set_ylabel("bank command (deg)"), ax[1].set_ylabel("c_l command"), ax[1].set_xlabel("navigation stamp (s)")
    ax[0].legend(fontsize=8)
    ax[0].set_title("commands, first seed")
    fig.tight_layout()
    fig.savefig(out / "commands.png", dpi=110)
    plt.close(fig)


def _data_note(sc) -> str:
    """What the figures hold on (the scenario's GNSS model)."""
    loop = "; closed loop offline on the live graph's cores (closed_loop.py)"
    if "raw" in sc.data["gnss"]:
        return ("realistic world (world.model " + sc.world_config().model + "): the raw-GNSS receiver's least-squares "
                "fixes with its own covariance, loosely coupled; blackouts as the receiver's loss of lock; the "
                "scenario's IMU error model" + loop)
    return "simulated world: white-noise loosely coupled GNSS fixes, the scenario's IMU error model" + loop


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="results/guidance")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--stream", default="both", choices=("both", "delayed", "current"))
    ap.add_argument("--scenario", default="guidance_glide")
    ap.add_argument("--short", action="store_true", help="one seed (the test's mode)")
    a = ap.parse_args(argv)
    run(pathlib.Path(a.out), 1 if a.short else a.seeds, a.stream, a.scenario)


if __name__ == "__main__":
    main()
