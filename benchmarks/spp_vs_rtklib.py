"""The whole ``spp`` command (start-up, read, solve, write .pos/.csv/.nmea/.kml/.gpx,
no plots) against RTKLIB's own ``postpos`` (pyrtklib, ``rtklib_postpos_run.py``),
each as a whole process on the same plain RINEX files and solution, in turn
(A B A B ...) in the same run: CPU and wall seconds of each (the median of
``--repeat`` runs after a warm-up, from the operating system's accounting of
the finished child), the ratio pair by pair, our per-epoch solve time and our
CPU by phase (start-up, read, solve, write: ``spp.json`` ``cpu_s``), and both
solutions' horizontal / vertical RMS against the header position (antenna
reference point) on their common epochs. ``spp`` is also timed once on the
files as shipped (compressed / Hatanaka: its own decompression included).

Run: python benchmarks/spp_vs_rtklib.py [OBS NAV...] [--mode dual|single] [--repeat N]
(default: the shared TLSE 15 min 1 Hz file and its day's navigation file;
then a 24 h, 30 s multi-GNSS file when ``--day OBS NAV`` is given or one is
found in the shared folder; none is there today, which it says, and a
simulated station's day stands in: 2,880 epochs of G+E+C on the IGS signal
set from the TLSE day's broadcast records, ``simulated_day``). Each file is
also run with ``spp --formats pos``: the one output file postpos writes.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
SHARED = pathlib.Path(os.environ.get("HYPER_NAV_SHARED") or HERE.parent / ".." / "shared")
TLSE = (SHARED / "real-data/tlse_2024001/TLSE00FRA_R_20240011200_15M_01S_MO.crx.gz",
        SHARED / "real-data/tlse_2024001/BRDC00IGS_R_20240010000_01D_MN.rnx.gz")
DAY_PATTERNS = ("*_01D_30S_MO.*", "*_01D_30S_MO", "*0.??o", "*0.??o.*", "*0.??d.*")   # a station's 24 h, 30 s file


def _timed(cmd) -> tuple[float, float, int]:
    """(CPU s, wall s, exit code) of one whole child process (its own rusage)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    return ru.ru_utime + ru.ru_stime, wall, p.returncode


def _spp_cmd() -> list[str]:
    return [sys.executable, "-m", "hyper_nav_workbench.spp"]


def find_day_file() -> tuple[str, list[str]] | None:
    """A 24 h, 30 s observation file under the shared folder and a
    navigation file beside it, or None."""
    for root in (SHARED / "real-data", SHARED / "gnss-real"):
        if not root.exists():
            continue
        for pat in DAY_PATTERNS:
            for obs in sorted(root.rglob(pat)):
                navs = [n for n in obs.parent.iterdir() if n != obs and ("_MN." in n.name or "_GN." in n.name
                                                                        or n.name.lower().endswith(("n", "n.gz", "p.gz")))]
                if navs:
                    return str(obs), [str(navs[0])]
    return None


def compare(obs, navs, mode: str, repeat: int, label: str) -> dict:
    from hyper_nav_gnss import earth
    from hyper_nav_gnss.formats.rinex_file import read_rinex_bytes
    from hyper_nav_workbench.core import spp_run
    from hyper_nav_workbench.core.importer.rtklib_pos import read_pos
    with tempfile.TemporaryDirectory(prefix="bench_spp_") as tmp:
        tmp = pathlib.Path(tmp)
        plain = [tmp / "obs.rnx"] + [tmp / f"nav{k}.rnx" for k in range(len(navs))]
        for src, dst in zip([obs, *navs], plain):
            dst.write_bytes(read_rinex_bytes(src))
        plain = [str(p) for p in plain]
        sysm = "GEC" if mode == "dual" else "G"
        a_cmd = _spp_cmd() + plain + ["--mode", mode, "--systems", sysm, "--out", str(tmp / "ours")]
        b_cmd = [sys.executable, str(HERE / "rtklib_postpos_run.py"), str(tmp / "rtklib.pos"), *plain,
                 "--mode", mode, "--systems", sysm]
        # the same command writing only what postpos writes (the .pos): like for like
        c_cmd = _spp_cmd() + plain + ["--mode", mode, "--systems", sysm, "--formats", "pos",
                                      "--out", str(tmp / "ours_pos")]
        a, b, c = [], [], []
        for k in range(repeat + 1):                  # the first round is a warm-up (file cache, bytecode)
            ra, rb, rc = _timed(a_cmd), _timed(b_cmd), _timed(c_cmd)
            if ra[2] != 0 or rb[2] != 0 or rc[2] != 0:
                raise SystemExit(f"exit codes spp {ra[2]}, postpos {rb[2]}, spp --formats pos {rc[2]}: {a_cmd} / "
                                 f"{b_cmd}")
            if k:
                a.append(ra)
                b.append(rb)
                c.append(rc)
        shipped = _timed(_spp_cmd() + [str(obs), *map(str, navs), "--mode", mode, "--systems", sysm,
                                       "--out", str(tmp / "shipped")])
        doc = json.loads((tmp / "ours" / "spp.json").read_text())
        pos = read_pos(next((tmp / "ours").glob("*.pos")))
        rk = read_pos(tmp / "rtklib.pos")
    run = next(iter(doc["runs"].values()))
    inp_hdr = spp_run.read_files(str(obs), [str(n) for n in navs], {"x": {"signals": {"G": ["1C"]}}},
                                 max_epochs=1).header
    ref = spp_run.header_reference(inp_hdr, str(obs))
    xo = np.asarray(earth.geodetic_to_ecef(pos.lat_rad, pos.lon_rad, pos.alt_m)).reshape(-1, 3)
    xr = np.asarray(earth.geodetic_to_ecef(rk.lat_rad, rk.lon_rad, rk.alt_m)).reshape(-1, 3)
    j = np.searchsorted(rk.t_gpst_s, pos.t_gpst_s).clip(0, max(len(rk.t_gpst_s) - 1, 0))
    common = (np.abs(rk.t_gpst_s[j] - pos.t_gpst_s) < 0.01) & (rk.quality[j] == 5) if len(rk.t_gpst_s) else \
        np.zeros(len(pos.t_gpst_s), bool)
    n = int(common.sum())
    so = spp_run.stats(spp_run.error_enu(xo[common], np.tile(ref.xyz_m, (n, 1)), ref.xyz_m))
    sr = spp_run.stats(spp_run.error_enu(xr[j[common]], np.tile(ref.xyz_m, (n, 1)), ref.xyz_m))
    med = statistics.median
    ratio_cpu = med([x[0] / y[0] for x, y in zip(a, b)])
    ratio_wall = med([x[1] / y[1] for x, y in zip(a, b)])
    ratio_pos_cpu = med([x[0] / y[0] for x, y in zip(c, b)])
    ratio_pos_wall = med([x[1] / y[1] for x, y in zip(c, b)])
    cpu = doc.get("cpu_s", {})
    n_ep = doc["epochs"]
    print(f"{label}: {pathlib.Path(obs).name} + {', '.join(pathlib.Path(n).name for n in navs)}; mode {mode} "
          f"({sysm}); {n_ep} epochs; {repeat} runs each after a warm-up, in turn; whole processes; medians")
    print(f"  spp (start-up + read + solve + write, plain files):  CPU {med(x[0] for x in a):7.2f} s, "
          f"wall {med(x[1] for x in a):7.2f} s")
    print(f"  RTKLIB postpos (start-up + read + solve + write):     CPU {med(x[0] for x in b):7.2f} s, "
          f"wall {med(x[1] for x in b):7.2f} s")
    print(f"  ratio spp / postpos, pair by pair:                    CPU {ratio_cpu:7.2f},   wall {ratio_wall:7.2f}")
    print(f"  spp --formats pos (the one file postpos writes):      CPU {med(x[0] for x in c):7.2f} s, "
          f"wall {med(x[1] for x in c):7.2f} s; ratio to postpos CPU {ratio_pos_cpu:.2f}, wall {ratio_pos_wall:.2f}")
    print(f"  spp CPU by phase (last run): start-up {cpu.get('startup', float('nan')):.2f} s, read "
          f"{cpu.get('read', float('nan')):.2f} s, solve {cpu.get('solve', float('nan')):.2f} s "
          f"({1e3 * cpu.get('solve', float('nan')) / max(n_ep, 1):.2f} ms per epoch; wall "
          f"{run['ms_per_epoch']:.2f} ms per epoch), write {cpu.get('write', float('nan')):.2f} s")
    print(f"  spp on the files as shipped (its decompression included), one run: CPU {shipped[0]:.2f} s, "
          f"wall {shipped[1]:.2f} s")
    print(f"  accuracy on the {n} common epochs vs the header position (ARP): ours H {so['horizontal_rms_m']:.3f} m, "
          f"V {so['vertical_rms_m']:.3f} m RMS; RTKLIB postpos H {sr['horizontal_rms_m']:.3f} m, "
          f"V {sr['vertical_rms_m']:.3f} m RMS")
    return {"ratio_cpu": ratio_cpu, "ratio_wall": ratio_wall, "ratio_pos_only_cpu": ratio_pos_cpu,
            "ratio_pos_only_wall": ratio_pos_wall, "epochs": n_ep,
            "spp_cpu_s": med(x[0] for x in a), "postpos_cpu_s": med(x[0] for x in b),
            "spp_pos_only_cpu_s": med(x[0] for x in c),
            "accuracy": {"ours": so, "rtklib_postpos": sr, "common_epochs": n}}


def simulated_day(folder: pathlib.Path, nav_path) -> tuple[str, list[str]]:
    """A 24 h, 30 s G+E+C station file simulated from the TLSE day's broadcast
    records (``hyper_nav_sim.core.gnss.station``: perfect model, IGS signal
    set, at TLSE's header position), written as RINEX 3.04 into ``folder``."""
    from hyper_nav_gnss.formats.rinex_nav import read_rinex_nav
    from hyper_nav_gnss.formats.rinex_obs_write import write_rinex3_obs
    from hyper_nav_gnss.orbits.ephemeris import calendar_to_system_s
    from hyper_nav_sim.core.gnss.station import simulate_station
    xyz = (4627852.5264, 119640.5140, 4372994.8358)              # TLSE's header position
    t0 = calendar_to_system_s("G", 2024, 1, 1, 0, 0, 0.0)
    eps, types = simulate_station(read_rinex_nav(nav_path), xyz, t0, t0 + 86400.0 - 30.0, 30.0, seed=1)
    out = folder / "SIMU00FRA_S_20240010000_01D_30S_MO.rnx"
    write_rinex3_obs(out, eps, types, xyz, 30.0, marker="SIMU",
                     comments=["simulated station (hyper_nav_sim.core.gnss.station), perfect model",
                               "broadcast records of BRDC00IGS_R_20240010000_01D_MN"])
    return str(out), [str(nav_path)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="*", help="OBS NAV... (default: the shared TLSE files)")
    ap.add_argument("--day", nargs="+", metavar="FILE", help="a 24 h, 30 s OBS file and its NAV file(s)")
    ap.add_argument("--mode", choices=("dual", "single"), default="dual")
    ap.add_argument("--repeat", type=int, default=3, help="counted runs of each (after one warm-up pair)")
    a = ap.parse_args(argv)
    files = [str(f) for f in (a.files or TLSE)]
    if len(files) < 2:
        ap.error("give OBS and at least one NAV file")
    print("(the machine may be shared with other jobs: the pair-by-pair ratios of the same run are what count)")
    compare(files[0], files[1:], a.mode, a.repeat, "file")
    day = (a.day[0], a.day[1:]) if a.day else (None if a.files else find_day_file())
    if day is None and not a.files:
        print(f"24 h, 30 s multi-GNSS file: none recorded (none under {SHARED / 'real-data'} or "
              f"{SHARED / 'gnss-real'}; give one with --day OBS NAV): a simulated station's day instead")
        with tempfile.TemporaryDirectory(prefix="bench_spp_day_") as tmp:
            t0 = time.perf_counter()
            obs, navs = simulated_day(pathlib.Path(tmp), TLSE[1])
            print(f"  (simulated in {time.perf_counter() - t0:.0f} s: {obs})")
            compare(obs, navs, a.mode, a.repeat, "24 h, 30 s simulated station (perfect model)")
    elif day is not None:
        compare(day[0], day[1], a.mode, a.repeat, "24 h file")
    return 0


if __name__ == "__main__":
    sys.exit(main())
