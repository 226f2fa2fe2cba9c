"""spp: single-point positioning of real receiver data, scored against a
reference, with RTKLIB's solution beside ours on the same epochs.

    ros2run hyper_nav_sim spp tlse                     # the shared TLSE RINEX (real_data/tlse.yaml)
    ros2run hyper_nav_sim spp walk                     # the shared u-blox walk log (real_data/walk.yaml)
    ros2run hyper_nav_sim spp my_receiver.yaml         # a description of your own files (core/spp_run.py)
    ros2run hyper_nav_sim spp --bag bags/imported      # gnss/raw + gnss/ephemeris of a bag (no RTKLIB)

Options: ``--out DIR`` (default ``results/spp_<name>``): ``spp.json`` (per
run: settings, counts, RAIM exclusions, statistics on all epochs and on the
epochs RTKLIB also solved, per-epoch series) and PNGs: ``errors_<run>.png``
(E/N/U error against time, ours and RTKLIB), ``skyplot.png`` (satellite tracks
coloured by C/N0, RAIM exclusions marked), ``residuals.png`` (residual
against elevation); ``--short N`` the first N epochs; ``--no-rtklib``;
``--data-dir`` the folder holding the shared recordings (default
``$HYPER_NAV_SHARED/real-data`` or ``../shared/real-data`` beside the repo).
Prints the read wall time, each run's figures and RTKLIB's beside them.
Exit 0, or 2 for a bad description / unreadable input.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys
import time

import numpy as np

from hyper_nav_filter.core.params import ConfigError

from .core import spp_run


def dataset_dirs() -> list[pathlib.Path]:
    dirs = []
    try:
        from ament_index_python.packages import get_package_share_directory
        dirs.append(pathlib.Path(get_package_share_directory("hyper_nav_sim")) / "real_data")
    except Exception:  # not installed: the source tree
        pass
    dirs.append(pathlib.Path(__file__).resolve().parents[1] / "real_data")
    return dirs


def default_data_dir() -> pathlib.Path:
    env = os.environ.get("HYPER_NAV_SHARED")
    if env:
        return pathlib.Path(env) / "real-data"
    return pathlib.Path(__file__).resolve().parents[3] / ".." / "shared" / "real-data"


def find_description(name: str) -> pathlib.Path:
    p = pathlib.Path(name)
    if p.suffix in (".yaml", ".yml") and p.exists():
        return p
    for d in dataset_dirs():
        if (d / f"{name}.yaml").exists():
            return d / f"{name}.yaml"
    raise ConfigError(f"spp: '{name}' is neither a description file nor a data set "
                      f"(looked in {[str(d) for d in dataset_dirs()]})")


def _json_default(x):
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return None if not np.isfinite(x) else float(x)
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, set):
        return sorted(x)
    return str(x)


def _clean(x):
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items() if not str(k).startswith("_")}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def plots(result: dict, out: pathlib.Path) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    written = []
    for name, r in result["runs"].items():
        s = r["series"]
        if "err_enu_m" not in s:
            continue
        t = np.array(s["t_gpst_s"])
        t = t - t[0]
        e = np.array(s["err_enu_m"], float)
        fig, ax = plt.subplots(3, 1, figsize=(10, 7), sharex=True)
        rk = np.array(s["rtklib_err_enu_m"], float) if "rtklib_err_enu_m" in s else None
        for i, lab in enumerate(("east", "north", "up")):
            ax[i].plot(t, e[:, i], lw=0.8, label="hyper-nav SPP")
            if rk is not None:
                ax[i].plot(t, rk[:, i], lw=0.8, alpha=0.7, label="RTKLIB pntpos")
            ax[i].set_ylabel(f"{lab} error [m]")
            ax[i].grid(alpha=0.3)
        st = r.get("ours_same_epochs", {})
        rs = r.get("rtklib_same_epochs", {})
        title = (f"{name}: ours H {st.get('horizontal_rms_m', float('nan')):.2f} m, "
                 f"V {st.get('vertical_rms_m', float('nan')):.2f} m RMS")
        if rs:
            title += (f"; RTKLIB H {rs.get('horizontal_rms_m', float('nan')):.2f} m, "
                      f"V {rs.get('vertical_rms_m', float('nan')):.2f} m (same {rs.get('epochs', 0)} epochs)")
        ax[0].set_title(title, fontsize=9)
        ax[0].legend(fontsize=8)
        ax[2].set_xlabel("time from first epoch [s]")
        fig.tight_layout()
        p = out / f"errors_{name}.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p.name)
    first = next(iter(result["runs"].values()))
    sols = first.get("_solutions") or []
    if sols:
        fig = plt.figure(figsize=(11, 5))
        ax = fig.add_subplot(1, 2, 1, projection="polar")
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        az, el, cn0, exc = [], [], [], []
        for sol in sols:
            ex = {x[0] for x in sol.excluded}
            for k, sid in enumerate(sol.sat_ids):
                az.append(sol.az_rad[k])
                el.append(np.rad2deg(sol.el_rad[k]))
                cn0.append(sol.cn0_dbhz[k])
                exc.append(sid in ex)
        az, el, cn0, exc = map(np.asarray, (az, el, cn0, exc))
        sc = ax.scatter(az, 90.0 - el, c=cn0, s=4, cmap="viridis")
        if exc.any():
            ax.scatter(az[exc], 90.0 - el[exc], marker="x", c="r", s=20, label="RAIM excluded")
            ax.legend(fontsize=8, loc="lower left")
        last = sols[-1]
        for k, sid in enumerate(last.sat_ids):
            ax.annotate(sid, (last.az_rad[k], 90.0 - np.rad2deg(last.el_rad[k])), fontsize=6)
        ax.set_rlim(0, 90)
        ax.set_yticks([0, 30, 60, 90])
        ax.set_yticklabels(["90", "60", "30", "0"])
        fig.colorbar(sc, ax=ax, label="C/N0 [dB-Hz] (first signal)")
        ax.set_title("skyplot (elevation deg)", fontsize=9)
        ax2 = fig.add_subplot(1, 2, 2)
        res = np.concatenate([s.residual_m[s.used] for s in sols])
        elu = np.concatenate([np.rad2deg(s.el_rad[s.used]) for s in sols])
        ax2.scatter(elu, res, s=2, alpha=0.4)
        ax2.set_xlabel("elevation [deg]")
        ax2.set_ylabel("post-fit residual [m]")
        ax2.grid(alpha=0.3)
        ax2.set_title(f"{next(iter(result['runs']))}: residuals of used satellites", fontsize=9)
        fig.tight_layout()
        fig.savefig(out / "skyplot.png", dpi=110)
        plt.close(fig)
        written.append("skyplot.png")
    return written


def _fmt(st: dict) -> str:
    if not st or not st.get("epochs"):
        return "no epoch"
    m = st["mean_enu_m"]
    return (f"H {st['horizontal_rms_m']:.3f} m, V {st['vertical_rms_m']:.3f} m RMS "
            f"(mean E/N/U {m[0]:+.2f}/{m[1]:+.2f}/{m[2]:+.2f} m; about the mean H "
            f"{st['horizontal_rms_about_mean_m']:.3f}, V {st['vertical_rms_about_mean_m']:.3f} m; "
            f"{st['epochs']} epochs)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="spp", description=__doc__.split("\n\n")[0])
    ap.add_argument("source", nargs="?", help="a data set name (tlse, walk) or a description YAML")
    ap.add_argument("--bag", help="a bag with gnss/raw and gnss/ephemeris instead of a description")
    ap.add_argument("--reference-xyz", nargs=3, type=float, help="reference point (ECEF, m) for a bag")
    ap.add_argument("--out", help="output folder (default results/spp_<name>)")
    ap.add_argument("--short", type=int, default=None, help="only the first N epochs")
    ap.add_argument("--no-rtklib", action="store_true", help="do not run RTKLIB beside")
    ap.add_argument("--no-plots", action="store_true")
    ap.add_argument("--data-dir", default=None, help="folder of the shared real-data recordings")
    args = ap.parse_args(argv)
    data_dir = pathlib.Path(args.data_dir) if args.data_dir else default_data_dir()
    try:
        if args.bag:
            doc = {"spp": {}}
            if args.reference_xyz:
                doc["reference"] = {"xyz_m": list(args.reference_xyz)}
            inp = spp_run.read_bag_input(args.bag, args.short)
            name = pathlib.Path(args.bag).name
        else:
            if not args.source:
                ap.error("give a data set name, a description YAML or --bag")
            desc = find_description(args.source)
            doc = spp_run.load_description(desc, data_dir)
            inp = spp_run.read_input(doc, args.short)
            name = desc.stem
        ref = spp_run.reference_of(doc)
    except (ConfigError, ValueError, OSError) as exc:
        print(f"spp: error: {exc}", file=sys.stderr)
        return 2
    print(f"[spp] {inp.source}: read in {inp.read_wall_s:.2f} s wall; {len(inp.epochs)} epochs, "
          f"{len(inp.records)} broadcast records; reader counts: "
          + ", ".join(f"{k} {v}" for k, v in sorted(inp.counts.items()) if v))
    t0 = time.perf_counter()
    result = spp_run.evaluate(inp, doc, ref, not args.no_rtklib,
                              progress=lambda s: print(f"[spp] {s} ...", file=sys.stderr, flush=True))
    print(f"[spp] reference: {result['reference']}")
    for rn, r in result["runs"].items():
        print(f"[spp] run {rn}: signals {r['signals']}, weighting {r['weighting']}, RAIM P_fa {r['p_fa']:g}; "
              f"{r['ms_per_epoch']:.1f} ms/epoch; status {r['status']}; mean satellites {r['mean_satellites_used']:.1f}, "
              f"PDOP {r['mean_pdop']:.2f}; RAIM exclusions {sum(r['exclusions'].values())} "
              f"{dict(sorted(r['exclusions'].items(), key=lambda kv: -kv[1])[:5])}")
        unhealthy = {k: v for k, v in r["counts"].items() if k.startswith("unhealthy_")}
        if unhealthy:
            print(f"[spp]   unhealthy satellites excluded (epochs): {unhealthy}")
        if "ours_all" in r:
            print(f"[spp]   ours, all {r['ours_all'].get('epochs', 0)} scored epochs: {_fmt(r['ours_all'])}")
        if "rtklib_same_epochs" in r:
            print(f"[spp]   ours,   same epochs as RTKLIB: {_fmt(r['ours_same_epochs'])}")
            rk = r["rtklib"]
            print(f"[spp]   RTKLIB {rk['ionosphere']} (codes {rk['codes']}, mean {rk['mean_satellites']:.1f} satellites, "
                  f"{rk['wall_s']:.1f} s): {_fmt(r['rtklib_same_epochs'])}")
        elif "rtklib" in r and "error" in r["rtklib"]:
            print(f"[spp]   RTKLIB did not run: {r['rtklib']['error']}")
    out = pathlib.Path(args.out or f"results/spp_{name}")
    out.mkdir(parents=True, exist_ok=True)
    written = [] if args.no_plots else plots(result, out)
    (out / "spp.json").write_text(json.dumps(_clean(result), indent=1, default=_json_default))
    print(f"[spp] wrote {out / 'spp.json'}" + (f", {', '.join(written)}" if written else "")
          + f" ({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
