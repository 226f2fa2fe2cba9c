"""Accuracy report of a recorded run: ``nav/state`` against ``truth/state``.

``report <bag>`` prints position (E/N/U), velocity and attitude error RMS and
max after the scenario's ``report.skip_s``, checks that nothing was lost
(publisher counts on /diagnostics against the messages in the bag), and
writes ``report.json`` and ``errors.png`` into the bag directory.
``replay_filter <bag>`` re-runs the fusion core offline over the bag's
sensor messages and reports the same figures for that solution.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

import numpy as np
import yaml

from hyper_nav_filter.core import earth
from hyper_nav_filter.core.attitude import attitude_error_n_rad, quat_xyzw_to_C
from hyper_nav_filter.conversions import stamp_to_s

from .core.bag import deserialize, read_bag


def states_from_msgs(msgs) -> dict:
    """Arrays (t, lat, lon, alt, vel, C) from NavState messages."""
    return {"t": np.array([stamp_to_s(m.header.stamp) for m in msgs]),
            "lat": np.array([m.lat_rad for m in msgs]), "lon": np.array([m.lon_rad for m in msgs]),
            "alt": np.array([m.alt_m for m in msgs]),
            "vel": np.array([np.asarray(m.vel_enu_mps, float) for m in msgs]).reshape(-1, 3),
            "C": np.array([quat_xyzw_to_C([m.q_b_enu.x, m.q_b_enu.y, m.q_b_enu.z, m.q_b_enu.w])
                           for m in msgs]).reshape(-1, 3, 3)}


def states_from_solutions(sols) -> dict:
    return {"t": np.array([s.t_s for s in sols]), "lat": np.array([s.state.lat_rad for s in sols]),
            "lon": np.array([s.state.lon_rad for s in sols]), "alt": np.array([s.state.alt_m for s in sols]),
            "vel": np.array([s.state.vel_enu_mps for s in sols]).reshape(-1, 3),
            "C": np.array([s.state.C_b_n for s in sols]).reshape(-1, 3, 3)}


def errors(nav: dict, truth: dict) -> dict:
    """Errors (estimate - truth) at the epochs both have (matched to 1 us)."""
    key_t = {round(t * 1e6): i for i, t in enumerate(truth["t"])}
    pairs = [(i, key_t[round(t * 1e6)]) for i, t in enumerate(nav["t"]) if round(t * 1e6) in key_t]
    if not pairs:
        raise ValueError("no common epochs between solution and truth")
    ni, ti = map(np.array, zip(*pairs))
    pos = earth.position_error_enu_m(nav["lat"][ni], nav["lon"][ni], nav["alt"][ni],
                                     truth["lat"][ti], truth["lon"][ti], truth["alt"][ti])
    vel = nav["vel"][ni] - truth["vel"][ti]
    att = np.array([attitude_error_n_rad(nav["C"][a], truth["C"][b]) for a, b in zip(ni, ti)])
    return {"t": nav["t"][ni], "pos_enu_m": pos, "vel_enu_mps": vel, "att_enu_deg": np.rad2deg(att)}


def summarize(err: dict, skip_s: float) -> dict:
    m = err["t"] >= skip_s
    if not m.any():
        raise ValueError(f"no solution epochs at or after report.skip_s = {skip_s} s "
                         f"(the run ends at {err['t'].max():.1f} s); lower it with --set report.skip_s=...")
    out = {"skip_s": skip_s, "epochs": int(m.sum())}
    for key in ("pos_enu_m", "vel_enu_mps", "att_enu_deg"):
        e = err[key][m]
        out[key] = {"rms_enu": np.sqrt(np.mean(e**2, axis=0)).tolist(),
                    "max_abs_enu": np.max(np.abs(e), axis=0).tolist(),
                    "rms_3d": float(np.sqrt(np.mean(np.sum(e**2, axis=1)))),
                    "max_3d": float(np.max(np.linalg.norm(e, axis=1)))}
    return out


def format_table(summary: dict, limits: dict | None = None, reference: dict | None = None) -> str:
    """Our figures, the issue's limits (3D RMS) and a paper's per-axis figures beside them."""
    names = {"pos_enu_m": ("position", "m"), "vel_enu_mps": ("velocity", "m/s"), "att_enu_deg": ("attitude", "deg")}
    ref = reference or {}
    lines = [f"accuracy after t >= {summary['skip_s']:.0f} s ({summary['epochs']} epochs)",
             f"{'':10s} {'unit':>5s} {'RMS E':>9s} {'RMS N':>9s} {'RMS U':>9s} {'RMS 3D':>9s} {'max 3D':>9s} "
             f"{'max|axis|':>9s}  {'limit RMS 3D':>14s}  {'paper/axis':>10s}"]
    for key, (label, unit) in names.items():
        s = summary[key]
        lim = (limits or {}).get(key)
        verdict = "" if lim is None else f"< {lim:<6g} {'PASS' if s['rms_3d'] < lim else 'FAIL'}"
        paper = ref.get(key)
        max_axis = max(s["max_abs_enu"])
        lines.append(f"{label:10s} {unit:>5s} " + " ".join(f"{x:9.4f}" for x in s["rms_enu"]) +
                     f" {s['rms_3d']:9.4f} {s['max_3d']:9.4f} {max_axis:9.4f}  {verdict:>14s}  "
                     + ("" if paper is None else f"< {paper:g}"))
    if ref.get("source"):
        lines.append(f"paper/axis: {ref['source']}")
    return "\n".join(lines)


def load_run(bag_path) -> dict:
    """Read a recorded run: nav and truth states, per-topic counts, the last
    diagnostics of each node, and whether the bag was truncated."""
    reader = read_bag(bag_path)
    nav, truth, last_diag = [], [], {}
    for rec in reader:
        topic = rec.topic.lstrip("/")
        if topic == "nav/state":
            nav.append(deserialize(rec.raw, rec.msgtype))
        elif topic == "truth/state":
            truth.append(deserialize(rec.raw, rec.msgtype))
        elif topic == "diagnostics":
            for st in deserialize(rec.raw, rec.msgtype).status:
                last_diag[st.name] = {kv.key: kv.value for kv in st.values}
    return {"nav": nav, "truth": truth, "counts": dict(reader.counts), "diagnostics": last_diag,
            "truncated": reader.truncated, "error": reader.error}


def delivery_check(run: dict) -> dict:
    """Published (from each node's last diagnostics) against recorded counts."""
    out = {}
    for name, values in run["diagnostics"].items():
        for key, val in values.items():
            if key.startswith("published "):
                topic = key.split(" ", 1)[1].lstrip("/")
                counts = {t.lstrip("/"): c for t, c in run["counts"].items()}
                out[topic] = {"published": int(val), "recorded": int(counts.get(topic, 0))}
    return out


def plot(err: dict, path: pathlib.Path, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    for ax, (key, label) in zip(axes, [("pos_enu_m", "position error [m]"), ("vel_enu_mps", "velocity error [m/s]"),
                                       ("att_enu_deg", "attitude error [deg]")]):
        for i, axis in enumerate("ENU"):
            ax.plot(err["t"], err[key][:, i], lw=0.8, label=axis)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", ncol=3)
    axes[-1].set_xlabel("sim time [s]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _limits(sc) -> dict:
    return {"pos_enu_m": sc["report.max_pos_rms_m"], "vel_enu_mps": sc["report.max_vel_rms_mps"],
            "att_enu_deg": sc["report.max_att_rms_deg"]}


def _reference(sc) -> dict:
    return {"pos_enu_m": sc["report.reference_pos_m"], "vel_enu_mps": sc["report.reference_vel_mps"],
            "att_enu_deg": sc["report.reference_att_deg"], "source": sc["report.reference_source"]}


def _scenario(args):
    from .graph import apply_overrides
    from .core.scenario import load_scenario
    import tempfile
    sc = load_scenario(args.scenario)
    overrides = {k: yaml.safe_load(v) for k, _, v in (s.partition("=") for s in args.set)}
    if overrides:
        sc = apply_overrides(sc, overrides, pathlib.Path(tempfile.mkdtemp(prefix="hyper_nav_report_")))
    return sc


def _args(argv, prog):
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    ap.add_argument("bag")
    ap.add_argument("--scenario", default="default")
    ap.add_argument("--set", action="append", default=[])
    if prog == "replay_filter":
        ap.add_argument("--smooth", action="store_true",
                        help="also run the fixed-interval RTS smoother and print its errors next to the filter's")
    return ap.parse_args(argv)


def main(argv=None) -> int:
    args = _args(argv, "report")
    bag = pathlib.Path(args.bag)
    sc = _scenario(args)
    run = load_run(bag)
    if run["truncated"]:
        print(f"[report] WARNING: bag is truncated ({run['error']}); reporting on what was readable")
    err = errors(states_from_msgs(run["nav"]), states_from_msgs(run["truth"]))
    summary = summarize(err, sc["report.skip_s"])
    delivery = delivery_check(run)
    limits = _limits(sc)
    print(format_table(summary, limits, _reference(sc)))
    lost = {t: d for t, d in delivery.items() if d["published"] != d["recorded"]}
    print(f"delivery: {len(delivery)} topics checked, "
          + ("nothing lost" if not lost else f"MISMATCH {lost}"))
    report = {"scenario": sc.name, "bag": str(bag), "truncated": run["truncated"], "summary": summary,
              "limits_rms_3d": limits, "paper_reference": _reference(sc), "delivery": delivery, "message_counts": run["counts"],
              "fusion_diagnostics": run["diagnostics"].get("hyper_nav_filter: fusion", {})}
    (bag / "report.json").write_text(json.dumps(report, indent=2))
    plot(err, bag / "errors.png", f"{sc.name}: nav/state - truth/state")
    print(f"[report] wrote {bag / 'report.json'} and {bag / 'errors.png'}")
    return 0


def replay_main(argv=None) -> int:
    """Offline: the fusion core over the bag's sensor messages."""
    from hyper_nav_filter.offline import run_offline
    args = _args(argv, "replay_filter")
    sc = _scenario(args)
    reader = read_bag(args.bag)
    from .graph import fusion_inputs
    inputs = fusion_inputs(sc) | {"truth/state"}
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in reader if r.topic.lstrip("/") in inputs]
    if reader.truncated:
        print(f"[replay_filter] WARNING: bag is truncated ({reader.error}); replaying what was readable")
    sols, eng = run_offline(records, sc.filter_config(), sc.filter_initial_state(), sources=sc.filter_sources(),
                            final=args.smooth, keep_history=args.smooth)
    truth = states_from_msgs([m for t, m in records if t.lstrip("/") == "truth/state"])
    summary = summarize(errors(states_from_solutions(sols), truth), sc["report.skip_s"])
    print(format_table(summary, _limits(sc), _reference(sc)))
    if args.smooth:
        from hyper_nav_filter.offline import smooth
        sm = summarize(errors(states_from_solutions(smooth(eng)), truth), sc["report.skip_s"])
        print("fixed-interval RTS smoother over the same pass:")
        print(format_table(sm, _limits(sc), _reference(sc)))
        print("filter vs smoother, RMS 3D: " + ", ".join(
            f"{k} {summary[k]['rms_3d']:.4g} -> {sm[k]['rms_3d']:.4g}" for k in ("pos_enu_m", "vel_enu_mps", "att_enu_deg")))
    print(f"engine counters: {dict(eng.counters)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
