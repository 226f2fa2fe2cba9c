"""The whole ``spp`` command (read, solve, write .pos/.csv/.nmea/.kml/.gpx,
no plots) against RTKLIB's own ``postpos`` (pyrtklib; decompression of the
same files included) on the same files and solution, in the same run:
wall times, the ratio, our per-epoch solve time, and both solutions'
horizontal / vertical RMS against the header position (antenna reference
point) on their common epochs.

Run: python benchmarks/spp_vs_rtklib.py [OBS NAV...] [--mode dual|single] [--repeat N]
(default: the shared TLSE 15 min 1 Hz file and its day's navigation file).
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys
import tempfile
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
SHARED = pathlib.Path(os.environ.get("HYPER_NAV_SHARED") or HERE.parent / ".." / "shared")
TLSE = (SHARED / "real-data/tlse_2024001/TLSE00FRA_R_20240011200_15M_01S_MO.crx.gz",
        SHARED / "real-data/tlse_2024001/BRDC00IGS_R_20240010000_01D_MN.rnx.gz")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="*", help="OBS NAV... (default: the shared TLSE files)")
    ap.add_argument("--mode", choices=("dual", "single"), default="dual")
    ap.add_argument("--repeat", type=int, default=1, help="runs of each (the best is reported)")
    a = ap.parse_args(argv)
    files = [str(f) for f in (a.files or TLSE)]
    from hyper_nav_workbench import spp
    from hyper_nav_workbench.core import rtklib_reference as rr
    from hyper_nav_workbench.core import spp_run
    from hyper_nav_workbench.core.importer.rtklib_pos import read_pos
    from hyper_nav_gnss import earth
    ours, theirs = [], []
    with tempfile.TemporaryDirectory(prefix="bench_spp_") as tmp:
        for k in range(a.repeat):
            t0 = time.perf_counter()
            rc = spp.main(files + ["--mode", a.mode, "--out", f"{tmp}/ours{k}"])
            ours.append(time.perf_counter() - t0)
            if rc != 0:
                print(f"spp exited {rc}", file=sys.stderr)
                return rc
            sysm = ("G", "E", "C") if a.mode == "dual" else ("G",)
            t0 = time.perf_counter()
            rk = rr.postpos_rinex(files[0], files[1:], sysm, a.mode == "dual", 10.0)
            theirs.append(time.perf_counter() - t0)
        best = int(np.argmin(ours))
        doc = json.loads(pathlib.Path(f"{tmp}/ours{best}/spp.json").read_text())
        run = next(iter(doc["runs"].values()))
        pos_file = next(pathlib.Path(f"{tmp}/ours{best}").glob("*.pos"))
        pos = read_pos(pos_file)
    inp_hdr = spp_run.read_files(files[0], files[1:], {"x": {"signals": {"G": ["1C"]}}}, max_epochs=1).header
    ref = spp_run.header_reference(inp_hdr, files[0])
    xyz = np.asarray(earth.geodetic_to_ecef(pos.lat_rad, pos.lon_rad, pos.alt_m)).reshape(-1, 3)
    k = np.array([np.argmin(np.abs(rk.t_gpst_s - t)) for t in pos.t_gpst_s]) if len(rk.t_gpst_s) else np.zeros(0, int)
    common = np.array([abs(rk.t_gpst_s[j] - t) < 0.01 and rk.ok[j] for j, t in zip(k, pos.t_gpst_s)], bool)
    eo = spp_run.error_enu(xyz[common], np.tile(ref.xyz_m, (common.sum(), 1)), ref.xyz_m)
    er = spp_run.error_enu(rk.pos_ecef_m[k[common]], np.tile(ref.xyz_m, (common.sum(), 1)), ref.xyz_m)
    so, sr = spp_run.stats(eo), spp_run.stats(er)
    n_ep = doc["epochs"]
    print(f"files: {', '.join(pathlib.Path(f).name for f in files)}; mode {a.mode}; {n_ep} epochs "
          f"(machine shared with other jobs: ratios of the same run are what count)")
    print(f"  spp (read {doc['read_wall_s']:.2f} s + solve {run['wall_s']:.2f} s + write; best run), whole command: "
          f"{min(ours):.2f} s; per-epoch solve {run['ms_per_epoch']:.2f} ms")
    print(f"  RTKLIB postpos (decompression + read + solve + write): {min(theirs):.2f} s; "
          f"{1e3 * min(theirs) / max(len(rk.t_gpst_s), 1):.2f} ms per solved epoch")
    print(f"  ratio spp / postpos: {min(ours) / min(theirs):.2f}")
    print(f"  accuracy on the {so['epochs']} common epochs vs the header position (ARP): "
          f"ours H {so['horizontal_rms_m']:.3f} m, V {so['vertical_rms_m']:.3f} m RMS; "
          f"RTKLIB postpos H {sr['horizontal_rms_m']:.3f} m, V {sr['vertical_rms_m']:.3f} m RMS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
