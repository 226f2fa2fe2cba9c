"""spp: single-point positioning of RINEX files or receiver logs; positions
out as RTKLIB .pos, CSV, NMEA, KML and GPX; scored against a reference and
RTKLIB beside it on request.

    spp OBS NAV [NAV ...]                      # RINEX files as archives hold them -> ./spp_<obs name>/
                                               #   <obs name>.pos .csv .nmea .kml .gpx (a station's day: one command)
    spp OBS NAV --ref header --rtklib          # scored against the header position, RTKLIB postpos beside
    spp tlse | walk | my_receiver.yaml         # a described campaign (core/spp_run.py: several runs, reference)
    spp --bag bags/imported                    # gnss/raw + gnss/ephemeris of a bag

Files: the observation file first (RINEX 2.11, 3.0x or 4.0x), then one or
more navigation files (RINEX 2 GPS, 3.0x mixed, 4.0x), each plain, .gz, .Z,
.zip, .bz2 and/or Hatanaka (.crx, .yyd), recognised by content. The
header's APPROX POSITION XYZ starts the first epoch; positions are those of
the antenna reference point (no phase-centre model), in WGS-84.

Modes (``--mode``): ``dual`` (default; ionosphere-free pairs: GPS L1C/A+L2P
(or L2C, L5), Galileo E1+E5b (or E5a), BDS B1I+B3I), ``single`` (GPS L1 C/A
with the navigation files' Klobuchar ionosphere), ``both``. ``--systems``
keeps some of G, E, C (e.g. ``--systems G``).

Precise orbits (``--sp3 FILE``, SP3-c/d, as archives hold them; ``--clk
FILE`` a RINEX CLK file for the clocks, else the SP3 clocks): they replace
the broadcast orbits and clocks of the systems the SP3 holds (10-point
Lagrange interpolation, linear clocks, relativistic term as for broadcast;
hyper_nav_gnss/orbits/precise.py); a satellite of those systems the
product cannot serve at an epoch is left out and counted (``precise_*``);
the other systems stay on broadcast. A product that does not cover the
observation span is refused (exit 2, both spans named). ``--atx FILE``
(ANTEX 1.4, e.g. igs20.atx): the satellites' antenna phase-centre offsets,
per signal or ionosphere-free pair, in the nominal yaw attitude; SP3
orbits are centres of mass, so without it each satellite's range is off
by its offset (0.6-1.6 m for GPS): a warning says so. The .pos header's
``orbits`` line says what was used. Broadcast records are still needed
(satellite selection, group delays).

Outputs (``--out DIR``, default ``./spp_<observation file name>`` in the
current directory; ``<name>.<ext>``, or ``<name>_<run>.<ext>`` for each run
with ``--mode both``): ``.pos``
(RTKLIB solution, Q=5), ``.csv`` (every epoch: status, geodetic and ECEF
position, sigmas, receiver clock and inter-system biases, DOPs, satellites
used / excluded by RAIM with the w-test / below the mask, RAIM statistic),
``.nmea`` (GGA, RMC, GSA, GST), ``.kml``, ``.gpx``; ``spp.json``
(settings, counts, statistics); PNGs with ``--plots``; with ``--fix-bag
DIR`` an MCAP bag of sensor_msgs/NavSatFix on /gnss/fix (also from
``--bag``: the bag's raw data in, NavSatFix out).

Exit 0, or 2 for bad input (a file that is not RINEX, an unknown version or
record, a file that yields nothing: the message names the file, the line
and what).
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

from hyper_nav_workbench.core import spp_run


def dataset_dirs() -> list[pathlib.Path]:
    dirs = []
    try:
        from ament_index_python.packages import get_package_share_directory
        dirs.append(pathlib.Path(get_package_share_directory("hyper_nav_workbench")) / "real_data")
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
                ax[i].plot(t, rk[:, i], lw=0.8, alpha=0.7, label=f"RTKLIB {r.get('rtklib', {}).get('engine', 'pntpos')}")
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


DIRECT_RUNS = {"dual": ("dual_frequency", spp_run.DEFAULT_RUNS["dual_frequency"]),
               "single": ("gps_single_frequency", spp_run.DEFAULT_RUNS["gps_single_frequency"])}
FORMATS = ("pos", "csv", "nmea", "kml", "gpx")


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="spp", description=__doc__.split("\n\n")[0].replace("\n", " "),
                                 epilog=__doc__.split("\n\n", 1)[1], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="*", metavar="OBS NAV... | NAME",
                    help="a RINEX observation file and its navigation file(s); or a campaign: a data set name "
                         "(tlse, walk) or a description YAML (core/spp_run.py)")
    ap.add_argument("--out", help="output folder (default ./spp_<name> in the current directory)")
    ap.add_argument("--mode", choices=("dual", "single", "both"), default="dual",
                    help="files: dual-frequency ionosphere-free (default), GPS L1 single frequency with "
                         "Klobuchar, or both")
    ap.add_argument("--systems", default="GEC", help="files: the systems to use, of G, E, C (default GEC)")
    ap.add_argument("--mask", type=float, default=10.0, metavar="DEG", help="files: elevation mask (default 10 deg)")
    ap.add_argument("--p-fa", type=float, default=1e-3,
                    help="files: RAIM false-alarm probability per epoch (default 1e-3)")
    ap.add_argument("--weighting", choices=("elevation", "cn0", "elevation_cn0"), default="elevation_cn0",
                    help="files: pseudorange weighting (core/gnss/weighting.py; default elevation_cn0)")
    ap.add_argument("--formats", default=",".join(FORMATS),
                    help=f"files: outputs to write, comma-separated of {','.join(FORMATS)} (default all)")
    ap.add_argument("--ref", metavar="REF",
                    help="score against a reference: 'header' (APPROX POSITION XYZ + ANTENNA: DELTA H/E/N), "
                         "X,Y,Z (ECEF m), LAT,LON,H (deg, deg, m) or an RTKLIB .pos file")
    ap.add_argument("--ref-quality", type=int, default=None,
                    help="with a .pos reference: only its epochs of this Q (1 = fixed)")
    ap.add_argument("--rtklib", action="store_true",
                    help="files: run RTKLIB (pyrtklib) beside ours on the same files and options")
    ap.add_argument("--no-rtklib", action="store_true", help="campaign: do not run RTKLIB beside")
    ap.add_argument("--plots", action="store_true", help="files: write the PNGs too")
    ap.add_argument("--no-plots", action="store_true", help="campaign: no PNGs")
    ap.add_argument("--short", type=int, default=None, metavar="N", help="only the first N epochs")
    ap.add_argument("--sp3", metavar="FILE",
                    help="files: precise orbits (SP3-c/d) instead of broadcast for the systems they hold; refused "
                         "unless they cover the observation span")
    ap.add_argument("--clk", metavar="FILE",
                    help="files, with --sp3: precise clocks (RINEX CLK) instead of the SP3 file's clocks")
    ap.add_argument("--atx", metavar="FILE",
                    help="files, with --sp3: ANTEX 1.4 file (e.g. igs20.atx) whose satellite antenna phase-centre "
                         "offsets move the precise orbits' centres of mass to the antenna (without it: a warning)")
    ap.add_argument("--bag", help="a bag with gnss/raw and gnss/ephemeris instead of files")
    ap.add_argument("--fix-bag", metavar="DIR",
                    help="also write the solutions as sensor_msgs/NavSatFix on /gnss/fix into an MCAP bag DIR "
                         "(stamps: GPST as seconds since 1970; full ENU covariance): for the player and the "
                         "fusion node's gnss source (first run when several)")
    ap.add_argument("--reference-xyz", nargs=3, type=float, help="reference point (ECEF, m) for a bag")
    ap.add_argument("--data-dir", default=None,
                    help="campaign: the folder holding the shared recordings (default $HYPER_NAV_SHARED/real-data "
                         "or ../shared/real-data beside the repo)")
    return ap


def _is_campaign(files) -> bool:
    if len(files) != 1:
        return False
    p = pathlib.Path(files[0])
    return p.suffix in (".yaml", ".yml") or not p.exists()


def _direct_doc(args) -> dict:
    systems = [c for c in args.systems.upper() if c.strip(",")]
    bad = [c for c in systems if c not in "GEC"]
    if bad or not systems:
        raise ConfigError(f"--systems {args.systems!r}: expected letters of G, E, C")
    runs = {}
    for m in (("dual", "single") if args.mode == "both" else (args.mode,)):
        name, run = DIRECT_RUNS[m]
        sig = {k: v for k, v in run["signals"].items() if k in systems}
        if not sig:
            raise ConfigError(f"--mode {m} with --systems {args.systems}: no system left "
                              f"(the {m} mode uses {', '.join(run['signals'])})")
        runs[name] = {"signals": sig}
    return {"preset": "rinex", "spp": {"elevation_mask_deg": args.mask, "p_fa": args.p_fa,
                                       "weighting": args.weighting, "rtklib": bool(args.rtklib), "runs": runs}}


def _stem(path) -> str:
    name = pathlib.Path(path).name
    for ext in (".gz", ".Z", ".zip", ".bz2", ".crx", ".rnx", ".CRX", ".RNX"):
        if name.endswith(ext):
            name = name[:-len(ext)]
    return name


def write_outputs(result: dict, out: pathlib.Path, stem: str, formats, header: dict) -> list[str]:
    """The positions of every run in the asked formats (core/spp_output.py)."""
    from hyper_nav_workbench.core import spp_output
    written = []
    single = len(result["runs"]) == 1
    for rn, r in result["runs"].items():
        sols = r.get("_solutions") or []
        base = stem if single else f"{stem}_{rn}"
        for f in formats:
            p = out / f"{base}.{f}"
            if f == "pos":
                h = dict(header)
                h["signals"] = " ".join(f"{k}:{'/'.join(v)}" for k, v in r["signals"].items())
                h["elev mask"] = f"{r['elevation_mask_deg']:.1f} deg"
                h["ionos opt"] = "ionosphere-free pairs" if any(
                    "+" in c for v in r["signals"].values() for c in v) else "broadcast (Klobuchar)"
                h["raim"] = f"chi-square global test P_fa {r['p_fa']:g}, w-test exclusion"
                n = spp_output.write_pos(p, sols, h)
            elif f in ("kml", "gpx"):
                n = spp_output.WRITERS[f](p, sols, name=f"{stem} {rn}")
            else:
                n = spp_output.WRITERS[f](p, sols)
            written.append(f"{p.name} ({n})")
    return written


def _print_result(inp, result) -> None:
    if inp.notes:
        for n in inp.notes:
            print(f"[spp] note: {n}")
    print(f"[spp] reference: {result['reference']}")
    for rn, r in result["runs"].items():
        print(f"[spp] run {rn}: signals {r['signals']}, weighting {r['weighting']}, RAIM P_fa {r['p_fa']:g}; "
              f"{r['ms_per_epoch']:.2f} ms/epoch; status {r['status']}; mean satellites {r['mean_satellites_used']:.1f}, "
              f"PDOP {r['mean_pdop']:.2f}; RAIM exclusions {sum(r['exclusions'].values())} "
              f"{dict(sorted(r['exclusions'].items(), key=lambda kv: -kv[1])[:5])}")
        for w in r.get("warnings", []):
            print(f"[spp]   WARNING: {w}")
        unhealthy = {k: v for k, v in r["counts"].items() if k.startswith("unhealthy_")}
        if unhealthy:
            print(f"[spp]   unhealthy satellites excluded (epochs): {unhealthy}")
        if "orbits" in r:
            pc = {k: v for k, v in sorted(r["counts"].items()) if k.startswith("precise_")}
            print(f"[spp]   precise orbits: satellite-epochs served / left out by reason: {pc}")
        if "ours_all" in r:
            print(f"[spp]   ours, all {r['ours_all'].get('epochs', 0)} scored epochs: {_fmt(r['ours_all'])}")
        if "rtklib_same_epochs" in r:
            print(f"[spp]   ours,   same epochs as RTKLIB: {_fmt(r['ours_same_epochs'])}")
            rk = r["rtklib"]
            print(f"[spp]   RTKLIB {rk['ionosphere']} ({rk['engine']}; codes {rk['codes']}, mean {rk['mean_satellites']:.1f} "
                  f"satellites, {rk['wall_s']:.1f} s): {_fmt(r['rtklib_same_epochs'])}")
        elif "rtklib" in r and "error" in r["rtklib"]:
            print(f"[spp]   RTKLIB did not run: {r['rtklib']['error']}")


def _reader_line(inp) -> str:
    missing = {k: v for k, v in inp.counts.items() if k.startswith("missing_code_") and v}
    n_err = inp.counts.get("errors", 0) - sum(missing.values())
    info = {k: v for k, v in sorted(inp.counts.items()) if v and k != "errors" and k not in missing}
    line = (f"[spp] {inp.source}: read in {inp.read_wall_s:.2f} s wall; {len(inp.epochs)} epochs, "
            f"{len(inp.records)} broadcast records; reader counts: " + ", ".join(f"{k} {v}" for k, v in info.items()))
    if missing:
        line += ("\n[spp] signals asked for that the file does not have (not an error): "
                 + ", ".join(k[len("missing_code_"):] for k in sorted(missing)))
    if n_err > 0:
        line += f"\n[spp] reader errors ({n_err}): " + "; ".join(
            e for e in inp.errors[:5] if "no C" not in e or "header" not in e)
    return line


def main(argv=None) -> int:
    cpu0 = time.process_time()              # the process's CPU so far: interpreter and imports (start-up)
    ap = parser()
    args = ap.parse_args(argv)
    data_dir = pathlib.Path(args.data_dir) if args.data_dir else default_data_dir()
    direct = bool(args.files) and not args.bag and not _is_campaign(args.files)
    precise = None
    try:
        if (args.sp3 or args.clk or args.atx) and not direct:
            raise ConfigError("--sp3 / --clk / --atx apply to files (spp OBS NAV... --sp3 FILE)")
        if (args.clk or args.atx) and not args.sp3:
            raise ConfigError("--clk and --atx need --sp3 (the orbits)")
        if args.bag:
            doc = {"spp": {}}
            if args.reference_xyz:
                doc["reference"] = {"xyz_m": list(args.reference_xyz)}
            inp = spp_run.read_bag_input(args.bag, args.short)
            name = pathlib.Path(args.bag).name
            ref = spp_run.reference_of(doc)
        elif direct:
            if len(args.files) < 2:
                ap.error("give the observation file and at least one navigation file")
            formats = [f.strip() for f in args.formats.split(",") if f.strip()]
            unknown = [f for f in formats if f not in FORMATS]
            if unknown:
                raise ConfigError(f"--formats: unknown {unknown[0]!r} (known: {', '.join(FORMATS)})")
            doc = _direct_doc(args)
            inp = spp_run.read_files(args.files[0], args.files[1:], doc["spp"]["runs"], args.short)
            name = _stem(args.files[0])
            ref = spp_run.parse_reference(args.ref, inp.header, args.files[0], args.ref_quality) if args.ref else None
            if args.sp3:
                precise = spp_run.load_precise(args.sp3, args.clk, inp.epochs, args.atx)
        else:
            if not args.files:
                ap.error("give RINEX files (OBS NAV...), a data set name, a description YAML or --bag")
            desc = find_description(args.files[0])
            doc = spp_run.load_description(desc, data_dir)
            inp = spp_run.read_input(doc, args.short)
            name = desc.stem
            ref = spp_run.reference_of(doc)
            if args.ref:
                ref = spp_run.parse_reference(args.ref, inp.header, inp.source, args.ref_quality)
    except (ConfigError, ValueError, OSError) as exc:
        print(f"spp: error: {exc}", file=sys.stderr)
        return 2
    print(_reader_line(inp))
    if precise is not None:
        print(f"[spp] orbits: {spp_run.precise_note(precise)}")
    cpu_read = time.process_time()
    t0 = time.perf_counter()
    with_rtklib = args.rtklib if direct else not args.no_rtklib
    result = spp_run.evaluate(inp, doc, ref, with_rtklib,
                              progress=lambda s: print(f"[spp] {s} ...", file=sys.stderr, flush=True),
                              precise=precise)
    cpu_solve = time.process_time()
    _print_result(inp, result)
    out = pathlib.Path(args.out or f"spp_{name}")
    out.mkdir(parents=True, exist_ok=True)
    written = []
    if direct:
        hdr = {"inp file": " ".join(str(pathlib.Path(f).name) for f in args.files)}
        if precise is not None:
            hdr["orbits"] = spp_run.precise_note(precise)
        written += write_outputs(result, out, name, formats, hdr)
    if args.fix_bag:
        from hyper_nav_workbench.core.spp_output import write_fix_bag
        first = next(iter(result["runs"].values()))
        n = write_fix_bag(args.fix_bag, first.get("_solutions") or [])
        written.append(f"{args.fix_bag} (/gnss/fix NavSatFix: {n})")
    if (direct and args.plots) or (not direct and not args.no_plots):
        written += plots(result, out)
    cpu_write = time.process_time()
    # CPU seconds of this process by phase (the solve includes RTKLIB when run beside; the write includes plots
    # when asked; spp.json's own writing is not counted)
    result["cpu_s"] = {"startup": cpu0, "read": cpu_read - cpu0, "solve": cpu_solve - cpu_read,
                       "write": cpu_write - cpu_solve}
    (out / "spp.json").write_text(json.dumps(_clean(result), indent=1, default=_json_default))
    print(f"[spp] wrote {out}/: spp.json" + (f", {', '.join(written)}" if written else "")
          + f" ({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
