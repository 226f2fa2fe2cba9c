"""Accuracy report of a recorded run: ``nav/state`` against ``truth/state``.

``report <bag>`` prints position (E/N/U), velocity and attitude error RMS and
max after the scenario's ``report.skip_s``, and the checks that decide its
verdict (``core/run_check.py``): every expected solution epoch scored (gaps
named), nothing lost between publishers, the recorder and the fusion node's
inputs (received and processed per input topic), no sensor stopped early,
no input rejected, no node died, no ERROR on /diagnostics, accuracy within
the scenario's limits. It ends with ``VERDICT: PASS`` or ``VERDICT: FAIL``
and the reasons, writes ``report.json`` (``verdict``, ``failures``,
``warnings`` and the details) and the run plots (``run_plots``: errors.png
with the filter's +/-3 sigma, consistency.png, track.png) into the bag directory, and
exits 0 (PASS), 1 (FAIL) or 2 (no report possible: unreadable bag, no truth
or no solution, bad scenario). The scenario is the bag's ``scenario.yaml``
(written by ``run_graph``) unless ``--scenario`` is given.
``replay_filter <bag>`` re-runs the fusion core offline over the bag's
sensor messages and reports the same figures and checks for that solution.
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
from hyper_nav_filter.replay_order import LATE_INPUTS_TOPIC

from .core import run_check
from .core.bag import deserialize, read_bag


class ReportError(Exception):
    """No report can be made (exit code 2); the message says why."""


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
    """Errors (estimate - truth) at the epochs both have (matched to 1 us),
    in time order whatever order the states came in (so every figure made
    from them, sums included, is independent of the arrival order)."""
    key_t = {round(t * 1e6): i for i, t in enumerate(truth["t"])}
    pairs = sorted((nav["t"][i], i, key_t[round(t * 1e6)]) for i, t in enumerate(nav["t"])
                   if round(t * 1e6) in key_t)
    if not pairs:
        raise ValueError("no common epochs between solution and truth")
    _, ni, ti = map(np.array, zip(*pairs))
    pos = earth.position_error_enu_m(nav["lat"][ni], nav["lon"][ni], nav["alt"][ni],
                                     truth["lat"][ti], truth["lon"][ti], truth["alt"][ti])
    vel = nav["vel"][ni] - truth["vel"][ti]
    att = np.array([attitude_error_n_rad(nav["C"][a], truth["C"][b]) for a, b in zip(ni, ti)])
    return {"t": nav["t"][ni], "pos_enu_m": pos, "vel_enu_mps": vel, "att_enu_deg": np.rad2deg(att)}


def effective_skip_s(skip_s: float, duration_s: float) -> tuple[float, str | None]:
    """``report.skip_s``, or half the run when the run is not longer than it
    (a 20 s bag with the default 30 s window); the note says so."""
    if skip_s < duration_s:
        return skip_s, None
    eff = 0.5 * duration_s
    return eff, (f"report.skip_s = {skip_s:g} s is not inside the {duration_s:g} s run: "
                 f"scoring from t >= {eff:g} s (half the run)")


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
    diagnostics of each status name and of each node, the timeline of every
    status (t, level, message, values), whether the bag was truncated, and
    ``run_graph.json`` (node exits) when it is there."""
    reader = read_bag(bag_path)
    nav, truth, last_diag, by_node, timeline, late = [], [], {}, {}, {}, []
    for rec in reader:
        topic = rec.topic.lstrip("/")
        if topic == "nav/state":
            nav.append(deserialize(rec.raw, rec.msgtype))
        elif topic == "truth/state":
            truth.append(deserialize(rec.raw, rec.msgtype))
        elif topic == "diagnostics":
            for st in deserialize(rec.raw, rec.msgtype).status:
                values = {kv.key: kv.value for kv in st.values}
                if _newer(values, last_diag.get(st.name)):
                    last_diag[st.name] = values
                if st.hardware_id and not st.name.startswith(run_check.MONITOR_PREFIX) and \
                        _newer(values, by_node.get(st.hardware_id)):
                    by_node[st.hardware_id] = values
                t = float(values.get("sim_time_s") or rec.t_ns * 1e-9)
                timeline.setdefault(st.name, []).append((t, run_check.level_of(st.level), st.message, values))
        elif topic == LATE_INPUTS_TOPIC:
            late.append(deserialize(rec.raw, rec.msgtype))
    for events in timeline.values():
        events.sort(key=lambda e: e[0])                   # stable: equal times keep their log order
    info = pathlib.Path(bag_path) / "run_graph.json"
    graph = json.loads(info.read_text()) if info.is_file() else {}
    return {"nav": nav, "truth": truth, "counts": dict(reader.counts), "diagnostics": last_diag,
            "by_node": by_node, "timeline": timeline, "truncated": reader.truncated, "error": reader.error,
            "run_graph": graph, "late_inputs": late}


def _newer(values: dict, old: dict | None) -> bool:
    """Whether a status (its key/values) is a node's later word than ``old``:
    by its ``heartbeat`` count (each node's own, increasing), so the last
    diagnostics of a node do not depend on the order the recorder got them;
    without heartbeats, the later in the log."""
    if old is None:
        return True
    try:
        return int(values["heartbeat"]) >= int(old["heartbeat"])
    except (KeyError, ValueError):
        return True


def late_inputs_summary(late_msgs) -> dict:
    """The fusion node's ``nav/late_inputs`` reports of a run, counted by
    outcome and topic (inputs received behind the IMU; those applied after
    their solution epoch was released are the ones the published solutions
    before them did not see)."""
    by_outcome, by_topic = {}, {}
    for m in late_msgs:
        by_outcome[m.outcome] = by_outcome.get(m.outcome, 0) + 1
        t = m.topic.lstrip("/")
        by_topic[t] = by_topic.get(t, 0) + 1
    return {"count": len(late_msgs), "by_outcome": by_outcome, "by_topic": by_topic}


def delivery_check(run: dict) -> dict:
    """Published (from each node's last diagnostics) against recorded counts
    (the simple view; the report's verdict uses ``run_check.delivery_rows``)."""
    out = {}
    for name, values in run["diagnostics"].items():
        for key, val in values.items():
            if key.startswith("published "):
                topic = key.split(" ", 1)[1].lstrip("/")
                counts = {t.lstrip("/"): c for t, c in run["counts"].items()}
                out[topic] = {"published": int(val), "recorded": int(counts.get(topic, 0))}
    return out


def _limits(sc) -> dict:
    return {"pos_enu_m": sc["report.max_pos_rms_m"], "vel_enu_mps": sc["report.max_vel_rms_mps"],
            "att_enu_deg": sc["report.max_att_rms_deg"]}


def _reference(sc) -> dict:
    return {"pos_enu_m": sc["report.reference_pos_m"], "vel_enu_mps": sc["report.reference_vel_mps"],
            "att_enu_deg": sc["report.reference_att_deg"], "source": sc["report.reference_source"]}


def _scenario(args):
    from .graph import apply_overrides, bag_scenario
    from .core.scenario import load_scenario
    import tempfile
    sc = load_scenario(args.scenario or bag_scenario(args.bag))
    overrides = {k: yaml.safe_load(v) for k, _, v in (s.partition("=") for s in args.set)}
    if overrides:
        sc = apply_overrides(sc, overrides, pathlib.Path(tempfile.mkdtemp(prefix="hyper_nav_report_")))
    return sc


def _args(argv, prog):
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    ap.add_argument("bag")
    ap.add_argument("--scenario", default=None, help="scenario name or YAML path (default: the bag's "
                    "scenario.yaml, else 'default')")
    ap.add_argument("--set", action="append", default=[])
    if prog == "replay_filter":
        ap.add_argument("--smooth", action="store_true",
                        help="also run the fixed-interval RTS smoother and print its errors next to the filter's")
        from . import replay_io
        replay_io.add_arguments(ap)          # imported data, truth files, KF-GINS outputs
    return ap.parse_args(argv)


def _guarded(prog, body, argv) -> int:
    """Run a command body; a report that cannot be made is a message and exit 2."""
    from .core.scenario import ScenarioError
    try:
        return body(argv)
    except (ReportError, ScenarioError, OSError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2


def main(argv=None) -> int:
    return _guarded("report", _report, argv)


def replay_main(argv=None) -> int:
    """Offline: the fusion core over the bag's sensor messages."""
    return _guarded("replay_filter", _replay, argv)


def _expected(sc, skip_s: float, end_s: float) -> np.ndarray:
    cfg = sc.filter_config()
    return run_check.expected_scored_epochs(end_s, sc["imu.rate_hz"], cfg.output_rate_hz,
                                            sc["graph.truth_rate_hz"], skip_s)


def _accuracy(summary: dict, limits: dict, out: run_check.Outcome) -> None:
    for key, lim in limits.items():
        if lim is not None and not summary[key]["rms_3d"] < lim:
            out.failures.append(f"accuracy: {key} RMS 3D {summary[key]['rms_3d']:.4g} not below the limit {lim:g}")


def _print_verdict(out: run_check.Outcome, prog: str) -> None:
    for w in out.warnings:
        print(f"[{prog}] warning: {w}")
    for f in out.failures:
        print(f"[{prog}] FAIL: {f}")
    reasons = sorted({f.split(":", 1)[0] for f in out.failures})
    print(f"VERDICT: {out.verdict}" + (f" ({len(out.failures)} failure(s): {', '.join(reasons)})"
                                       if out.failures else " (nothing lost, every expected epoch scored)"))


def _score(nav_states: dict, truth_states: dict, sc, out: run_check.Outcome, end_s: float | None = None):
    """Errors, summary and the epoch check up to ``end_s`` (default: the
    scenario's end); (err, summary) or (None, None) without a solution."""
    if len(truth_states["t"]) == 0:
        raise ReportError("no truth/state in the bag: nothing to score against")
    end_s = sc["duration_s"] if end_s is None else end_s
    skip, note = effective_skip_s(sc["report.skip_s"], end_s)
    if note:
        out.warnings.append(note)
    # every solution epoch of the run must be there (a gap before the accuracy window is lost data too)
    run_check.epoch_check(nav_states["t"], _expected(sc, 0.0, end_s), out)
    try:
        err = errors(nav_states, truth_states)
        summary = summarize(err, skip)
    except ValueError as exc:
        out.failures.append(f"accuracy: not computed: {exc}")
        return None, None
    _accuracy(summary, _limits(sc), out)
    return err, summary


def _report(argv) -> int:
    args = _args(argv, "report")
    bag = pathlib.Path(args.bag)
    if not bag.exists():
        raise ReportError(f"{bag}: no such bag")
    sc = _scenario(args)
    run = load_run(bag)
    out = run_check.Outcome()
    if not run["counts"]:
        raise ReportError(f"{bag}: no readable messages" + (f" ({run['error']})" if run["error"] else ""))
    if run["truncated"]:
        print(f"[report] WARNING: bag is truncated ({run['error']}); reporting on what was readable")
        out.failures.append(f"bag: truncated: {run['error']}")
    nav, truth = states_from_msgs(run["nav"]), states_from_msgs(run["truth"])
    rg = run["run_graph"]
    end_s = None
    if rg.get("interrupted"):                # score what was flown; the run itself fails
        flown = nav["t"] if len(nav["t"]) else truth["t"]
        end_s = float(flown.max()) if len(flown) else 0.0
        out.failures.append(f"run: interrupted by {rg['interrupted']} ({rg.get('stopped_by', '')}); "
                            f"scored what was flown, up to t = {end_s:.1f} s of {sc['duration_s']:g} s")
    err, summary = _score(nav, truth, sc, out, end_s)
    if summary is not None:
        print(format_table(summary, _limits(sc), _reference(sc)))
    exits = run["run_graph"].get("exits", [])
    dead = {e["ros_name"] for e in exits}
    for name, events in run["timeline"].items():
        if name.startswith(run_check.MONITOR_PREFIX + "node ") and events and events[-1][1] == 2:
            dead.add(name[len(run_check.MONITOR_PREFIX + "node "):])
    rows = run_check.delivery_rows(run["by_node"], run["counts"], out, dead)
    if not rg.get("interrupted"):
        run_check.schedule_rows(run["by_node"], out)
    run_check.input_truncated(run["by_node"], out)
    fusion = run["by_node"].get(run_check.FUSION_NODE, {})
    run_check.rejected_inputs(fusion, out)
    run_check.bridged_gaps(fusion, out)
    run_check.status_faults(run["timeline"], out, exits)
    late = late_inputs_summary(run["late_inputs"])
    out.details["late_inputs"] = late
    if late["count"]:
        print(f"late inputs at the fusion node (received behind the IMU, replayed where received): {late['count']} "
              f"{late['by_outcome']}")
    if late["by_outcome"].get("applied_after_release"):
        out.warnings.append(f"late inputs: {late['by_outcome']['applied_after_release']} measurement(s) reached the "
                            f"fusion node after their solution epoch was released; solutions published before "
                            f"them did not use them (filter.config.output_delay_s is below that lateness)")
    ep = out.details["epochs"]
    print(f"epochs: {ep['scored']} of {ep['expected']} expected solution epochs (with truth) published")
    print(f"delivery: {len(rows)} topics checked: " + ", ".join(
        f"{t} {r.get('published', '-')}/{r['recorded']}" + "".join(
            f"/{v}" for k, v in sorted(r.items()) if k.startswith(("received_by", "processed_by")))
        for t, r in sorted(rows.items())) + "  (published/recorded[/processed/received at fusion])")
    _print_verdict(out, "report")
    report = {"scenario": sc.name, "bag": str(bag), "verdict": out.verdict, "failures": out.failures,
              "warnings": out.warnings, "truncated": run["truncated"], "summary": summary,
              "limits_rms_3d": _limits(sc), "paper_reference": _reference(sc), **out.details,
              "message_counts": run["counts"], "node_exits": exits,
              "fusion_diagnostics": run["diagnostics"].get("hyper_nav_filter: fusion", {})}
    if err is not None:
        from . import run_plots                              # errors with +/-3 sigma, consistency, track
        report["plots"] = run_plots.write(bag, run, sc, errors)
    (bag / "report.json").write_text(json.dumps(report, indent=2, default=float))
    print(f"[report] wrote {bag / 'report.json'}" + (f", errors.png, consistency.png and track.png in {bag}"
                                                     if err is not None else ""))
    return 0 if out.verdict == "PASS" else 1


def _replay(argv) -> int:
    from hyper_nav_filter.offline import run_offline
    args = _args(argv, "replay_filter")
    if not pathlib.Path(args.bag).exists():
        raise ReportError(f"{args.bag}: no such bag")
    from . import replay_io
    if replay_io.handles(args):
        return replay_io.main(args)
    sc = _scenario(args)
    reader = read_bag(args.bag)
    from .graph import fusion_inputs
    inputs = fusion_inputs(sc) | {"truth/state", LATE_INPUTS_TOPIC}   # the node's late inputs: its own order
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in reader if r.topic.lstrip("/") in inputs]
    out = run_check.Outcome()
    if not records:
        raise ReportError(f"{args.bag}: no readable sensor messages" + (f" ({reader.error})" if reader.error else ""))
    if reader.truncated:
        print(f"[replay_filter] WARNING: bag is truncated ({reader.error}); replaying what was readable")
        out.failures.append(f"bag: truncated: {reader.error}")
    # final: at the end of the bag every solution is released (as the live node does at shutdown)
    sols, eng = run_offline(records, sc.filter_config(), sc.filter_initial_state(), sources=sc.filter_sources(),
                            final=True, keep_history=args.smooth)
    truth = states_from_msgs([m for t, m in records if t.lstrip("/") == "truth/state"])
    _, summary = _score(states_from_solutions(sols), truth, sc, out)
    if summary is not None:
        print(format_table(summary, _limits(sc), _reference(sc)))
    n_imu = sum(1 for t, _ in records if t.lstrip("/") == "imu/data_raw")
    if eng.counters["imu_accepted"] != n_imu:
        out.failures.append(f"inputs: imu/data_raw: {n_imu} in the bag, {eng.counters['imu_accepted']} "
                            f"accepted by the filter")
    run_check.rejected_inputs(dict(eng.counters), out)
    run_check.bridged_gaps(dict(eng.counters), out)
    if args.smooth and summary is not None:
        from hyper_nav_filter.offline import smooth
        sm = summarize(errors(states_from_solutions(smooth(eng)), truth), summary["skip_s"])
        print("fixed-interval RTS smoother over the same pass:")
        print(format_table(sm, _limits(sc), _reference(sc)))
        print("filter vs smoother, RMS 3D: " + ", ".join(
            f"{k} {summary[k]['rms_3d']:.4g} -> {sm[k]['rms_3d']:.4g}" for k in ("pos_enu_m", "vel_enu_mps", "att_enu_deg")))
    ro = eng.replay
    print(f"replay order: stamp order, {ro.placed} input(s) the live node received behind the IMU fed where it "
          f"received them" + (f"; {len(ro.missing)} reported late input(s) not in the bag" if ro.missing else ""))
    print(f"engine counters: {dict(eng.counters)}")
    _print_verdict(out, "replay_filter")
    return 0 if out.verdict == "PASS" else 1


if __name__ == "__main__":
    sys.exit(main())
