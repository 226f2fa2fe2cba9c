"""The user's offline path, whole process (``make bench``): ``import_data`` of
the peer-format data set (``peer_dataset.py``: 672,399 IMU epochs at 200 Hz,
3,362 GNSS fixes, a 200 Hz truth file) and ``replay_filter --truth ...
--write-nav --write-std`` on the bag, each timed from outside as its own
process (wall and CPU seconds, the child's own accounting), beside the C++
peer KF-GINS on the same files in the same run.

The peer (``--peer``, on by default in ``make bench``) is built from its
source archive (``peer_kfgins.py``: ``../shared/peers``, into a folder under
the system's temporary directory, never into the repository) and run on the
same IMU and GNSS files with the same filter (``peer_dataset.peer_yaml``:
21 states, the same noise, initial state and sigmas), writing its own .nav,
STD and IMU-error text files; both whole-process times and their ratio are
reported. On a machine without the archive or a compiler the peer is
skipped, and the report says so (no figure from elsewhere stands in).

``loop`` times the replay loop alone (the fusion core over the bag's arrays,
``run_offline_arrays``, in a process of its own after the bag is read) and
gives the engine's cost per IMU epoch; ``--reference`` also times the
per-message path of the same steps in the same run (the bag written one
message object at a time, replayed from deserialized messages through
``run_offline``, scored and written epoch by epoch, as the commands did
before the array path) and compares the two solutions: the largest
difference of any .nav / STD column.

    python benchmarks/user_path.py [--data DIR] [--duration-s 3362] [--peer] [--reference] [--json PATH]
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import resource
import subprocess
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent


def timed(cmd: list[str], log=None) -> dict:
    """Wall and CPU seconds of one command as its own process (children's rusage)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if log is not None:
        pathlib.Path(log).write_text(p.stdout)
    if p.returncode != 0:
        raise RuntimeError(f"{cmd[:3]} exited {p.returncode}:\n{p.stdout[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall_s": wall, "cpu_s": cpu, "output": p.stdout}


def _py(code: str, *args) -> list[str]:
    return [sys.executable, "-c", code, *map(str, args)]


IMPORT = "import sys; from hyper_nav_workbench.import_data import main; sys.exit(main(sys.argv[1:]))"
REPLAY = "import sys; from hyper_nav_workbench.replay_filter import main; sys.exit(main(sys.argv[1:]))"
REF_IMPORT = ("import sys; from hyper_nav_workbench import import_data as m; "
              "m.write(m.load_import(sys.argv[1]), sys.argv[2], per_message=True)")
REF_REPLAY = "import sys; sys.path.insert(0, sys.argv[1]); import user_path; user_path.reference(*sys.argv[2:])"
LOOP = "import sys; sys.path.insert(0, sys.argv[1]); import user_path; user_path.loop_only(*sys.argv[2:])"


def loop_only(bag) -> None:
    """The replay loop of ``replay_filter`` alone (``run_offline_arrays`` over
    the bag's arrays, with the final release), timed in this process after the
    bag is read; prints one JSON line: loop wall and CPU seconds, IMU epochs,
    solutions."""
    from hyper_nav_filter.filter_setup import FilterSetup
    from hyper_nav_filter.offline_arrays import run_offline_arrays
    from hyper_nav_filter.sources import make_sources, parse_sources
    from hyper_nav_workbench.core.bag_arrays import read_arrays
    setup = FilterSetup.load(pathlib.Path(bag) / "filter.yaml")
    inputs = {i.topic.lstrip("/") for src in make_sources(parse_sources(setup.sources), setup.config)
              for i in src.inputs()}
    topics = [t for name, t in read_arrays(bag).topics.items() if name.lstrip("/") in inputs]
    run_offline_arrays(topics[:0], setup.config, setup.initial, sources=setup.sources)   # kernels loaded
    c0, t0 = time.process_time(), time.perf_counter()
    sols, eng, _ = run_offline_arrays(topics, setup.config, setup.initial, sources=setup.sources, final=True)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(json.dumps({"wall_s": wall, "cpu_s": cpu, "imu_epochs": eng.counters["imu_accepted"],
                      "solutions": len(sols)}))


def reference(bag, truth, nav_out, std_out) -> None:
    """``replay_filter BAG --truth TRUTH --write-nav --write-std`` on the per-message path, as the command
    ran before the array path: one message object per record (rosbags), ``run_offline``, scoring epoch by
    epoch (``importer.score``, unchanged) and ``np.savetxt``."""
    import numpy as np
    from hyper_nav_filter.core.attitude import C_b_n_to_euler
    from hyper_nav_filter.filter_setup import FilterSetup
    from hyper_nav_filter.offline import run_offline
    from hyper_nav_workbench.core import scoring
    from hyper_nav_workbench.replay_filter import sigma_blocks
    from hyper_nav_workbench.core.bag import deserialize, read_bag
    from hyper_nav_workbench.core.importer import columns, kfgins, score
    setup = FilterSetup.load(pathlib.Path(bag) / "filter.yaml")
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(bag)]
    sols, eng = run_offline(records, setup.config, setup.initial, sources=setup.sources, final=True)
    nav = scoring.states_from_solutions(sols)
    tab = columns.fix_table({**kfgins.NAV, "file": str(pathlib.Path(truth).resolve())}, pathlib.Path(truth).parent,
                            "truth")
    err = score.errors_against(nav, tab)
    err = {**err, "t": err["t"] - setup.initial.t_s}
    print(scoring.format_table(scoring.summarize(err, setup.skip_s)))
    rph = np.array([C_b_n_to_euler(s.state.C_b_n) for s in sols])
    np.savetxt(nav_out, kfgins.nav_rows(nav["t"], nav["lat"], nav["lon"], nav["alt"], nav["vel"], rph),
               fmt="%.9f", delimiter=" ")
    np.savetxt(std_out, kfgins.std_rows(nav["t"], sigma_blocks(sols, setup.config.layout)),
               fmt="%.9f", delimiter=" ")
    print(f"engine counters: {dict(eng.counters)}")


def _max_diff(a, b) -> float:
    import numpy as np
    x, y = np.loadtxt(a), np.loadtxt(b)
    if x.shape != y.shape:
        return float("inf")
    d = np.abs(x - y)
    return float(np.nanmax(d)) if np.isfinite(d).any() else 0.0


def _rms_line(text: str) -> str:
    return next((ln for ln in text.splitlines() if ln.startswith("position")), "")


def machine() -> dict:
    """The machine the figures were measured on: host, CPU model, cores, load."""
    import platform
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")),
               platform.processor()) if os.path.exists("/proc/cpuinfo") else platform.processor()
    d = {"host": platform.node(), "cpu": cpu, "cores": os.cpu_count(), "load_1min": os.getloadavg()[0],
         "python": platform.python_version(), "system": f"{platform.system()} {platform.release()}"}
    d["text"] = f"{d['host']}: {cpu}, {d['cores']} cores, load {d['load_1min']:.1f}, Python {d['python']}"
    return d


def run_peer(data_dir, work, rebuild: bool = False, log=print) -> dict:
    """Build (or find the earlier build of) KF-GINS and time its whole process
    on the data set; {"skipped": reason} when it cannot be built here."""
    import peer_dataset
    import peer_kfgins
    exe, info = peer_kfgins.build(rebuild, log=log)
    if exe is None:
        return info
    cfg = peer_dataset.peer_yaml(data_dir, pathlib.Path(work) / "peer")
    r = timed([str(exe), str(cfg)], log=pathlib.Path(work) / "peer" / "stdout.txt")
    rows = sum(1 for _ in open(pathlib.Path(work) / "peer" / "KF_GINS_Navresult.nav"))
    return {**info, **r, "nav_rows": rows, "command": f"{exe} {cfg}"}


def run(data_dir, duration_s: float, reference_path: bool = False, peer: bool = False, work=None,
        log=print, rebuild_peer: bool = False) -> dict:
    import tempfile
    sys.path.insert(0, str(HERE))
    import peer_dataset
    imp = peer_dataset.write(data_dir, duration_s, log=log)
    d = pathlib.Path(data_dir)
    if work is None:                  # a folder of our own (a bag and outputs, about 1 GB): removed after the run
        import shutil
        tmp = pathlib.Path(tempfile.mkdtemp(prefix="hyper_nav_user_path_"))
        try:
            return run(data_dir, duration_s, reference_path, peer, tmp, log, rebuild_peer)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    work = pathlib.Path(work)
    n_imu = sum(1 for _ in open(d / "imu.txt")) - 1
    out = {"data": str(d), "imu_epochs": n_imu, "machine": machine(), "load_before": os.getloadavg()[0]}
    out["import"] = timed(_py(IMPORT, imp, "--out", work / "bag"))
    out["replay"] = timed(_py(REPLAY, work / "bag", "--truth", d / "truth.nav", "--write-nav", work / "new.nav",
                              "--write-std", work / "new_std.txt"))
    if reference_path:
        out["reference_import"] = timed(_py(REF_IMPORT, imp, work / "bag_ref"))
        out["reference_replay"] = timed(_py(REF_REPLAY, HERE, work / "bag", d / "truth.nav", work / "ref.nav",
                                            work / "ref_std.txt"))
        out["max_abs_diff_nav"] = _max_diff(work / "new.nav", work / "ref.nav")
        out["max_abs_diff_std"] = _max_diff(work / "new_std.txt", work / "ref_std.txt")
        out["position_rms_reference"] = _rms_line(out["reference_replay"]["output"])
    out["position_rms"] = _rms_line(out["replay"]["output"])
    out["nav_rows"] = sum(1 for _ in open(work / "new.nav"))
    loop = timed(_py(LOOP, HERE, work / "bag"))
    out["loop"] = {**json.loads(loop["output"].strip().splitlines()[-1]), "process_wall_s": loop["wall_s"]}
    if peer:
        out["peer"] = run_peer(d, work, rebuild_peer, log=log)
    else:
        out["peer"] = {"skipped": "not asked for (--peer)"}
    out["load_after"] = os.getloadavg()[0]
    for k in list(out):
        if isinstance(out[k], dict):
            out[k].pop("output", None)
    return out


def report_lines(r: dict, engine_us: float | None = None) -> list[str]:
    """The report of ``run``: both whole-process times and their ratio, the loop alone, per epoch."""
    n = r["imu_epochs"]
    lines = [f"== the user's path on the peer-format set ({n} IMU epochs), whole process, same files, "
             f"same run, load {r['load_before']:.1f} -> {r['load_after']:.1f} ==",
             f"  machine {r['machine']['text']}"]
    for step in ("import", "replay"):
        x = r[step]
        ref = r.get(f"reference_{step}")
        lines.append(f"  {step:7s} {x['wall_s']:7.1f} s wall {x['cpu_s']:7.1f} s CPU"
                     + (f"   per-message path {ref['wall_s']:7.1f} s wall {ref['cpu_s']:7.1f} s CPU "
                        f"(x{ref['wall_s'] / x['wall_s']:.1f} wall)" if ref else ""))
    ours = r["import"]["wall_s"] + r["replay"]["wall_s"]
    lo = r["loop"]
    lines.append(f"  hyper-nav, import + replay: {ours:.1f} s wall; replay loop alone {lo['wall_s']:.1f} s "
                 f"({lo['wall_s'] / n * 1e6:.1f} us per IMU epoch, {n / 200.0 / lo['wall_s']:.0f}x real time)"
                 + (f"; engine bench {engine_us:.1f} us per epoch" if engine_us else ""))
    p = r.get("peer", {})
    if "wall_s" in p:
        built = ", build reused" if p.get("reused") else f", built in {p['build_s']:.0f} s"
        lines.append(f"  KF-GINS (C++, Release, built from {pathlib.Path(p['archive']).name}{built}): "
                     f"{p['wall_s']:.1f} s wall {p['cpu_s']:.1f} s CPU ({p['wall_s'] / n * 1e6:.1f} us per IMU "
                     f"epoch, whole process with its text I/O; {p['nav_rows']} .nav rows, ours {r['nav_rows']})")
        ours_cpu = r["import"]["cpu_s"] + r["replay"]["cpu_s"]
        lines.append(f"  replay / peer {r['replay']['wall_s'] / p['wall_s']:.2f}; import + replay / peer "
                     f"{ours / p['wall_s']:.2f}; replay loop alone / peer {lo['wall_s'] / p['wall_s']:.2f} "
                     f"(wall, whole processes, same files, same run)")
        lines.append(f"  by CPU seconds (each process's own: the fairer figure on a shared machine): replay / peer "
                     f"{r['replay']['cpu_s'] / p['cpu_s']:.2f}; import + replay / peer {ours_cpu / p['cpu_s']:.2f}; "
                     f"replay loop alone / peer {lo['cpu_s'] / p['cpu_s']:.2f} ({lo['cpu_s'] / n * 1e6:.1f} against "
                     f"{p['cpu_s'] / n * 1e6:.1f} us CPU per IMU epoch)")
    else:
        lines.append(f"  replay / peer: not measured: KF-GINS skipped ({p.get('skipped', 'not run')})")
    if "max_abs_diff_nav" in r:
        lines.append(f"  array path vs per-message path: largest difference .nav {r['max_abs_diff_nav']:.3g}, "
                     f"STD {r['max_abs_diff_std']:.3g}")
    lines.append(f"  {r['position_rms']}")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(HERE / ".data" / "peer"))
    ap.add_argument("--duration-s", type=float, default=3362.0)
    ap.add_argument("--reference", action="store_true")
    ap.add_argument("--peer", action="store_true", help="build KF-GINS from ../shared/peers and run it beside ours")
    ap.add_argument("--rebuild-peer", action="store_true", help="build the peer afresh (else an earlier build is reused)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    r = run(a.data, a.duration_s, a.reference, a.peer, rebuild_peer=a.rebuild_peer)
    print("\n".join(report_lines(r)))
    if a.json:
        pathlib.Path(a.json).write_text(json.dumps(r, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
