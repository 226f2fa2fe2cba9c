"""Accuracy report of a recorded run: the fusion node's two streams against ``truth/state``.

The verdict scores the record: the delayed, arrival-order-independent
solutions (``nav/delayed/state``; ``nav/state`` in bags recorded before the
current-time output, issue 35). The current-time stream (``nav/state``, one
state per IMU sample, predicted over the fusion horizon) is scored beside it
at its own stamps: position / velocity RMS and NEES (``current_time`` in
report.json).

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
(written by ``run_graph``) unless ``--scenario`` is given. The scoring
itself (errors, summary, limits, the table, the verdict) is
``core/scoring.py``; ``replay_filter`` scores a re-run of the fusion core the
same way.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

from hyper_nav_filter.replay_order import LATE_INPUTS_TOPIC

from hyper_nav_workbench.core import run_check, scoring, verdict_rules
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_sim.core.scenario import ScenarioError, scenario_of_run
from hyper_nav_workbench.core.scoring import ScoringError


def load_run(bag_path) -> dict:
    """Read a recorded run: nav and truth states, per-topic counts, the last
    diagnostics of each status name and of each node, the timeline of every
    status (t, level, message, values), whether the bag was truncated, and
    ``run_graph.json`` (node exits) when it is there."""
    reader = read_bag(bag_path)
    nav, current, truth, last_diag, by_node, timeline, late = [], [], [], {}, {}, {}, []
    for rec in reader:
        topic = rec.topic.lstrip("/")
        if topic == DELAYED_TOPIC:
            nav.append(deserialize(rec.raw, rec.msgtype))
        elif topic == "nav/state":
            current.append(deserialize(rec.raw, rec.msgtype))
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
    if not nav and DELAYED_TOPIC not in {t.lstrip("/") for t in reader.topics}:
        nav, current = current, []             # a bag from before issue 35: nav/state was the released stream
    return {"nav": nav, "current": current, "truth": truth, "counts": dict(reader.counts), "diagnostics": last_diag,
            "by_node": by_node, "timeline": timeline, "truncated": reader.truncated, "error": reader.error,
            "run_graph": graph, "late_inputs": late}


DELAYED_TOPIC = "nav/delayed/state"


def current_time_summary(current_msgs, truth: dict, skip_s: float) -> dict | None:
    """The current-time stream (``nav/state``) at its own stamps after
    ``skip_s``: position / velocity RMS 3D and max, mean position and
    velocity NEES (3 dof each, its own covariance), epochs scored."""
    import numpy as np
    if not current_msgs:
        return None
    nav = scoring.states_from_msgs(current_msgs)
    try:
        err = scoring.errors(nav, truth)
    except ValueError:
        return None
    m = err["t"] >= skip_s
    if not m.any():
        return None
    by_t = {round(scoring.stamp_to_s(msg.header.stamp), 6): msg for msg in current_msgs}
    nees_p, nees_v = [], []
    for t, ep, ev in zip(err["t"][m], err["pos_enu_m"][m], err["vel_enu_mps"][m]):
        msg = by_t[round(float(t), 6)]
        n = int(msg.state_dim)
        P = np.asarray(msg.covariance, float).reshape(n, n)
        pp, vv = P[6:9, 6:9], P[3:6, 3:6]            # att, vel, pos first (core.state_layout)
        nees_p.append(ep @ np.linalg.solve(pp, ep))
        nees_v.append(ev @ np.linalg.solve(vv, ev))
    pos, vel = err["pos_enu_m"][m], err["vel_enu_mps"][m]
    return {"epochs": int(m.sum()), "skip_s": skip_s,
            "pos_rms_3d_m": float(np.sqrt(np.mean(np.sum(pos ** 2, axis=1)))),
            "pos_max_3d_m": float(np.max(np.linalg.norm(pos, axis=1))),
            "vel_rms_3d_mps": float(np.sqrt(np.mean(np.sum(vel ** 2, axis=1)))),
            "nees_pos_mean": float(np.mean(nees_p)), "nees_vel_mean": float(np.mean(nees_v))}


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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="report", description=__doc__.split("\n\n")[0])
    ap.add_argument("bag")
    ap.add_argument("--scenario", default=None, help="scenario name or YAML path (default: the bag's "
                    "scenario.yaml, else 'default')")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", help="override a scenario field")
    args = ap.parse_args(argv)
    try:
        return _report(args)
    except (ScoringError, ScenarioError, OSError) as exc:
        print(f"report: error: {exc}", file=sys.stderr)
        return 2


def _report(args) -> int:
    bag = pathlib.Path(args.bag)
    if not bag.exists():
        raise ScoringError(f"{bag}: no such bag")
    sc = scenario_of_run(bag, args.scenario, args.set)
    run = load_run(bag)
    out = run_check.Outcome()
    if not run["counts"]:
        raise ScoringError(f"{bag}: no readable messages" + (f" ({run['error']})" if run["error"] else ""))
    if run["truncated"]:
        print(f"[report] WARNING: bag is truncated ({run['error']}); reporting on what was readable")
        out.failures.append(f"bag: truncated: {run['error']}")
    nav, truth = scoring.states_from_msgs(run["nav"]), scoring.states_from_msgs(run["truth"])
    rg = run["run_graph"]
    end_s = None
    if rg.get("interrupted"):                # score what was flown; the run itself fails
        flown = nav["t"] if len(nav["t"]) else truth["t"]
        end_s = float(flown.max()) if len(flown) else 0.0
        out.failures.append(f"run: interrupted by {rg['interrupted']} ({rg.get('stopped_by', '')}); "
                            f"scored what was flown, up to t = {end_s:.1f} s of {sc['duration_s']:g} s")
    err, summary = scoring.score(nav, truth, sc, out, end_s)
    if summary is not None:
        print(scoring.format_table(summary, scoring.limits(sc), scoring.reference(sc)))
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
    per_source = verdict_rules.from_values(fusion)          # gated/accepted/NIS per source, and the rules
    print(verdict_rules.format_table(per_source))
    verdict_rules.check(per_source, out)
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
    lost = run_check.delivery_losses(rows)
    print(("delivery: nothing lost, published == recorded == received == processed on every topic; "
           if not lost else f"delivery: MESSAGES LOST on {', '.join(lost)}; ") + f"{len(rows)} topics checked: " + ", ".join(
        f"{t} {r.get('published', '-')}/{r['recorded']}" + "".join(
            f"/{v}" for k, v in sorted(r.items()) if k.startswith(("received_by", "processed_by")))
        for t, r in sorted(rows.items())) + "  (published/recorded[/processed/received at fusion])")
    cur = current_time_summary(run["current"], truth, summary["skip_s"] if summary else sc["report.skip_s"])
    if cur is not None:
        out.details["current_time"] = cur
        delayed = (summary or {}).get("pos_enu_m", {}).get("rms_3d")
        print(f"current-time stream (nav/state, {cur['epochs']} states after {cur['skip_s']:g} s): position RMS 3D "
              f"{cur['pos_rms_3d_m']:.3f} m (delayed {delayed if delayed is None else f'{delayed:.3f}'} m), max "
              f"{cur['pos_max_3d_m']:.3f} m, velocity RMS 3D {cur['vel_rms_3d_mps']:.4f} m/s; mean NEES position "
              f"{cur['nees_pos_mean']:.2f}, velocity {cur['nees_vel_mean']:.2f} (3 dof)")
    code = scoring.verdict(out, "report")
    report = {"scenario": sc.name, "bag": str(bag), "verdict": out.verdict, "failures": out.failures,
              "warnings": out.warnings, "truncated": run["truncated"], "summary": summary,
              "limits_rms_3d": scoring.limits(sc), "paper_reference": scoring.reference(sc), **out.details,
              "message_counts": run["counts"], "node_exits": exits,
              "fusion_diagnostics": run["diagnostics"].get("hyper_nav_filter: fusion", {})}
    if err is not None:
        from hyper_nav_workbench import run_plots
        report["plots"] = run_plots.write(bag, run, sc)
    (bag / "report.json").write_text(json.dumps(report, indent=2, default=float))
    print(f"[report] wrote {bag / 'report.json'}" + (f", errors.png, consistency.png and track.png in {bag}"
                                                     if err is not None else ""))
    return code


if __name__ == "__main__":
    sys.exit(main())
