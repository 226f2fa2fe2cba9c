"""The user's offline path, whole process (``make bench``): ``import_data`` of
the peer-format data set (``peer_dataset.py``: 672,399 IMU epochs at 200 Hz,
3,362 GNSS fixes, a 200 Hz truth file) and ``replay_filter --truth ...
--write-nav --write-std`` on the bag, each timed from outside as its own
process (wall and CPU seconds, the child's own accounting).

``--reference`` also times the per-message path of the same steps in the
same run (``reference`` below: the bag written one message object at a time,
replayed from deserialized messages through ``run_offline``, scored and
written epoch by epoch, as the commands did before the array path) and
compares the two solutions: the largest difference of any .nav / STD
column. ``--peer CMD`` times the C++ peer (KF-GINS built from its source,
``CMD`` its command line on a configuration over the same files) in the same
run; without it the peer's figure is the one measured elsewhere (issue 25).

    python benchmarks/user_path.py [--data DIR] [--duration-s 3362] [--reference] [--peer "kf-gins cfg.yaml"]
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import resource
import shlex
import subprocess
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
PEER_ELSEWHERE_S = 17.8          # KF-GINS whole process on the peer's own set, issue 25 (measured elsewhere)


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


IMPORT = "import sys; from hyper_nav_sim.import_data import main; sys.exit(main(sys.argv[1:]))"
REPLAY = "import sys; from hyper_nav_sim.replay_filter import main; sys.exit(main(sys.argv[1:]))"
REF_IMPORT = ("import sys; from hyper_nav_sim import import_data as m; "
              "m.write(m.load_import(sys.argv[1]), sys.argv[2], per_message=True)")
REF_REPLAY = "import sys; sys.path.insert(0, sys.argv[1]); import user_path; user_path.reference(*sys.argv[2:])"


def reference(bag, truth, nav_out, std_out) -> None:
    """``replay_filter BAG --truth TRUTH --write-nav --write-std`` on the per-message path, as the command
    ran before the array path: one message object per record (rosbags), ``run_offline``, scoring epoch by
    epoch (``importer.score``, unchanged) and ``np.savetxt``."""
    import numpy as np
    from hyper_nav_filter.core.attitude import C_b_n_to_euler
    from hyper_nav_filter.filter_setup import FilterSetup
    from hyper_nav_filter.offline import run_offline
    from hyper_nav_sim.core import scoring
    from hyper_nav_sim.replay_filter import sigma_blocks
    from hyper_nav_sim.core.bag import deserialize, read_bag
    from hyper_nav_sim.core.importer import columns, kfgins, score
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


def run(data_dir, duration_s: float, reference_path: bool = False, peer: str | None = None, work=None,
        log=print) -> dict:
    import tempfile
    sys.path.insert(0, str(HERE))
    import peer_dataset
    imp = peer_dataset.write(data_dir, duration_s, log=log)
    d = pathlib.Path(data_dir)
    work = pathlib.Path(work or tempfile.mkdtemp(prefix="hyper_nav_user_path_"))
    n_imu = sum(1 for _ in open(d / "imu.txt")) - 1
    out = {"data": str(d), "imu_epochs": n_imu, "load_before": os.getloadavg()[0]}
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
    if peer:
        out["peer"] = timed(shlex.split(peer))
    out["load_after"] = os.getloadavg()[0]
    for k in list(out):
        if isinstance(out[k], dict):
            out[k].pop("output", None)
    return out


def report_lines(r: dict, engine_us: float | None = None) -> list[str]:
    lines = [f"== the user's path on the peer-format set ({r['imu_epochs']} IMU epochs), whole process, "
             f"load {r['load_before']:.1f} -> {r['load_after']:.1f} =="]
    peer = r.get("peer", {}).get("wall_s")
    peer_txt = f"{peer:.1f} s (KF-GINS, this run)" if peer else f"{PEER_ELSEWHERE_S:.1f} s (KF-GINS, measured elsewhere)"
    for step in ("import", "replay"):
        x = r[step]
        ref = r.get(f"reference_{step}")
        lines.append(f"  {step:7s} {x['wall_s']:7.1f} s wall {x['cpu_s']:7.1f} s CPU"
                     + (f"   per-message path {ref['wall_s']:7.1f} s wall {ref['cpu_s']:7.1f} s CPU "
                        f"(x{ref['wall_s'] / x['wall_s']:.1f} wall)" if ref else ""))
    lines.append(f"  replay / peer {r['replay']['wall_s'] / (peer or PEER_ELSEWHERE_S):.2f} ({peer_txt})"
                 + (f"; engine alone {engine_us * r['imu_epochs'] * 1e-6:.1f} s ({engine_us:.1f} us x epochs)"
                    if engine_us else ""))
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
    ap.add_argument("--peer", default=None)
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    r = run(a.data, a.duration_s, a.reference, a.peer)
    print("\n".join(report_lines(r)))
    if a.json:
        pathlib.Path(a.json).write_text(json.dumps(r, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
