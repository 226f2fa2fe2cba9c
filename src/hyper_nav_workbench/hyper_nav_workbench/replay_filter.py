"""replay_filter: the fusion core re-run offline over a recorded bag, scored
the way ``report`` scores the live run.

    replay_filter bags/my_run                            # the bag's scenario.yaml sets the filter
    replay_filter bags/my_run --smooth                   # and the fixed-interval RTS smoother beside it
    replay_filter bags/my_drive                          # an imported bag: its filter.yaml (import_data)
    replay_filter bags/my_drive --truth truth.nav        # score against a truth file (KF-GINS .nav layout)
    replay_filter bags/my_drive --write-nav out.nav --write-std out_std.txt   # KF-GINS formats

The filter comes from ``--filter FILE``, else ``<bag>/filter.yaml``, else
the scenario (``--scenario``, else the bag's ``scenario.yaml``, with
``--set``). The bag's messages on the topics of the declared sources go
through the core, read as field arrays (``core/bag_arrays``,
``hyper_nav_filter.offline_arrays``; in the live node's own order where it
reported late inputs: ``hyper_nav_filter.replay_order``); at the end of
the bag every solution is released, as the live node does at shutdown.
Progress (sim time, real-time factor, ETA) goes to stderr while the core
runs. Scoring (``core/scoring.py``): against ``--truth`` (any sampling,
interpolated to the solution epochs, ``core.importer.score``), else against
``truth/state`` in the bag. A scenario's replay is checked as its live run
is (every expected solution epoch scored, every IMU sample of the bag
accepted, no input rejected, no IMU gap bridged, the scenario's accuracy
limits); a replay of imported data against what its setup declares.

Both of the live node's streams (issue 35): the delayed solutions above (the
record, ``nav/delayed/state``) and the current-time stream, one state per
IMU sample (``nav/state``), replayed in the node's own arrival order and
scored at its own stamps (position / velocity RMS, NEES); a recording that
has both is compared with them bit for bit (``--no-current`` skips the
current-time stream: it keeps a state per IMU sample in memory). Ends
with ``VERDICT: PASS`` or ``VERDICT: FAIL``; exit 0 (PASS), 1 (FAIL) or 2
(no replay possible: no such or unreadable bag, bad scenario or setup).
"""
from __future__ import annotations

import argparse
import contextlib
import gc
import pathlib
import sys
from dataclasses import dataclass

import numpy as np
import yaml

from hyper_nav_filter.core.params import ConfigError

from hyper_nav_workbench.core import noise_check, run_check, scoring, verdict_rules
from hyper_nav_sim.core.scenario import ScenarioError, scenario_of_run
from hyper_nav_workbench.core.scoring import ScoringError


@dataclass
class Setup:
    """What the replay runs and scores with."""
    config: object                # FilterConfig
    initial: object               # NavState
    sources: dict                 # the filter.sources table
    skip_s: float
    limits: dict
    reference: dict
    scenario: object = None       # the Scenario (None for an imported bag's filter.yaml)


def add_arguments(ap) -> None:
    ap.add_argument("bag")
    ap.add_argument("--scenario", default=None, help="scenario name or YAML path (default: the bag's "
                    "scenario.yaml, else 'default')")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", help="override a scenario field")
    ap.add_argument("--no-current", action="store_true", help="do not replay and score the current-time stream")
    ap.add_argument("--smooth", action="store_true",
                    help="also run the fixed-interval RTS smoother and print its errors next to the filter's")
    ap.add_argument("--filter", help="filter setup file (default: <bag>/filter.yaml, written by import_data)")
    ap.add_argument("--truth", help="truth file to score against (KF-GINS .nav layout unless --truth-map)")
    ap.add_argument("--truth-map", help="column map (YAML, core/importer/columns.py fields) of the --truth file")
    ap.add_argument("--write-nav", metavar="FILE", help="write the solution in the KF-GINS .nav format")
    ap.add_argument("--write-nav-at", choices=("imu", "antenna"), default="imu",
                    help="--write-nav at the IMU (the filter's state) or at the GNSS antenna (the lever arm "
                         "antenna_lever_arm_b_m applied: position + C_b_n l_b, velocity + C_b_n (omega x l_b))")
    ap.add_argument("--write-std", metavar="FILE", help="write the standard deviations in the KF-GINS STD format")


def setup(args) -> Setup:
    """The filter setup file (``--filter`` or the bag's ``filter.yaml``), else the scenario."""
    from hyper_nav_filter.filter_setup import FilterSetup
    path = pathlib.Path(args.filter) if args.filter else pathlib.Path(args.bag) / "filter.yaml"
    if args.filter or path.exists():
        s = FilterSetup.load(path)
        return Setup(s.config, s.initial, s.sources, s.skip_s, {}, {})
    sc = scenario_of_run(args.bag, args.scenario, args.set)
    return Setup(sc.filter_config(), sc.filter_initial_state(), sc.filter_sources(), sc["report.skip_s"],
                 scoring.limits(sc), scoring.reference(sc), sc)


def truth_table(args):
    """The ``--truth`` file as a ``columns.FixTable`` with velocity and attitude."""
    from hyper_nav_workbench.core.importer import columns, kfgins
    path = pathlib.Path(args.truth)
    spec = yaml.safe_load(pathlib.Path(args.truth_map).read_text()) if args.truth_map else dict(kfgins.NAV)
    spec = {**spec, "file": str(path.resolve())}
    return columns.fix_table(spec, path.parent, "truth")


def sigma_blocks(sols, layout) -> dict:
    """{block: (n, 3) 1-sigma} of the 3-element blocks of the solutions' covariance (ENU convention):
    sqrt(max(diag(s.P), 0)) of each solution, the diagonals taken as views of the covariances
    (``fusion.solution_covariances``: the same arrays as ``s.P``) and the root over the stack (peer-format set,
    168,101 solutions: np.diag and the root per solution 0.47 s, this 0.18 s, CPU, same process)."""
    from hyper_nav_filter.core.fusion import solution_covariances
    Ps = solution_covariances(sols)
    n = Ps[0].shape[0] if len(Ps) else 0
    diag = np.array([P.diagonal() for P in Ps]).reshape(-1, n)
    d = np.sqrt(np.maximum(diag, 0.0))
    return {name: d[:, layout.sl(name)] for name in layout.names if layout.sl(name).stop - layout.sl(name).start == 3}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="replay_filter", description=__doc__.split("\n\n")[0])
    add_arguments(ap)
    args = ap.parse_args(argv)
    try:
        return _replay(args)
    except (ScoringError, ScenarioError, ConfigError, OSError) as exc:
        print(f"replay_filter: error: {exc}", file=sys.stderr)
        return 2
    finally:
        gc.unfreeze()                 # (_collector_off: a caller in the same process gets its collector back whole)


# message types the field arrays cannot give back as messages (a string sequence split into columns):
# replayed from deserialized messages, the other topics from arrays
PER_MESSAGE_TYPES = frozenset({"hyper_nav_msgs/msg/GnssMeasurements", "hyper_nav_msgs/msg/GnssEphemeris"})


def _run(bag, s: Setup, inputs: set, keep_history: bool, keep_current: bool = False):
    """The fusion core over the bag's input topics, with progress on stderr.
    The bag is read into field arrays (``core/bag_arrays``) and the core fed
    from them (``hyper_nav_filter.offline_arrays``: ``run_offline``'s results
    bit for bit, in stamp order; raw GNSS and ephemeris messages as
    deserialized messages beside the arrays, ``PER_MESSAGE_TYPES``); a
    recording of a live node that got inputs behind the IMU
    (``nav/late_inputs``) replays on the per-message path in the node's own
    order (``replay_order``). Returns (solutions, engine,
    truth states or None, IMU count, reader error, truncated)."""
    from hyper_nav_filter.offline_arrays import run_offline_arrays
    from hyper_nav_filter.replay_order import LATE_INPUTS_TOPIC

    from hyper_nav_workbench.core import array_io
    from hyper_nav_workbench.core.bag_arrays import read_arrays
    from hyper_nav_workbench.progress import Progress
    arrays = read_arrays(bag)
    topics = [t for name, t in arrays.topics.items() if name.lstrip("/") in inputs]
    truth = next((t for name, t in arrays.topics.items() if name.lstrip("/") == "truth/state"), None)
    late = next((t for name, t in arrays.topics.items() if name.lstrip("/") == LATE_INPUTS_TOPIC), None)
    if not any(len(t) for t in topics):
        raise ScoringError(f"{bag}: no readable sensor messages" + (f" ({arrays.error})" if arrays.error else ""))
    stamps = [t.stamp_s for t in topics if len(t)]
    t0, t1 = min(float(x.min()) for x in stamps), max(float(x.max()) for x in stamps)
    progress = Progress("replay_filter", total=t1 - t0)
    if late is not None and len(late):
        from hyper_nav_filter.offline import run_offline

        from hyper_nav_workbench.core.bag import deserialize, read_bag
        records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(bag)
                   if r.topic.lstrip("/") in inputs | {LATE_INPUTS_TOPIC}]
        sols, eng = run_offline(records, s.config, s.initial, sources=s.sources, final=True,
                                keep_history=keep_history, keep_current=keep_current)
    else:
        # gnss/raw carries a string sequence (``signal``) that the field arrays split into one column per
        # index (signal.0, signal.1, ...) and a row view cannot read back as a sequence: those topics are
        # deserialized message by message (``MessageTopic``), the rest stays on arrays
        per_message = {t.topic for t in topics if t.msgtype in PER_MESSAGE_TYPES and len(t)}
        if per_message:
            from hyper_nav_filter.offline_arrays import MessageTopic

            from hyper_nav_workbench.core.bag import deserialize, read_bag
            recs: dict[str, list] = {t: [] for t in per_message}
            for r in read_bag(bag, topics=per_message):
                recs[r.topic].append((r.t_ns, deserialize(r.raw, r.msgtype)))
            msgtype = {t.topic: t.msgtype for t in topics}
            topics = [t for t in topics if t.topic not in per_message] + \
                [MessageTopic(name, msgtype[name], [m for _, m in rows], [n for n, _ in rows])
                 for name, rows in recs.items() if rows]
        n_fed = sum(len(t) for t in topics)
        with _collector_off():
            sols, eng, _ = run_offline_arrays(topics, s.config, s.initial, sources=s.sources, final=True,
                                              keep_history=keep_history, keep_current=keep_current,
                                              progress=lambda k: progress.update((t1 - t0) * k / max(n_fed, 1)))
    progress.update(t1 - t0)
    progress.done(f"{len(sols)} solutions")
    n_imu = sum(len(t) for t in topics if t.topic.lstrip("/") == "imu/data_raw")
    truth_states = array_io.states_from_topic(truth) if truth is not None and len(truth) else None
    return sols, eng, truth_states, n_imu, arrays.error, arrays.truncated


@contextlib.contextmanager
def _collector_off():
    """The replay without the cyclic garbage collector, and what it made
    (every solution, the current-time log: millions of objects that live to
    the end of the command) moved out of the collector's view after it
    (``gc.freeze``; ``main`` undoes it at its end). The replay loop makes no
    cyclic garbage (``offline_arrays._young_collections_only``); what the
    collector cost here: its young collections during the loop and a full
    collection over the whole heap right after it, then more during scoring
    (peer-format set, 672,400 epochs: 4-5 s of a 20 s command, cProfile)."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if was:
            gc.enable()


def _errors(nav: dict, args, truth_states, initial_t_s: float) -> dict:
    """Errors against the truth file or the bag's truth/state, timed from the
    initial epoch (``report.skip_s`` counts from it)."""
    from hyper_nav_workbench.core.importer import score
    err = score.errors_against(nav, truth_table(args)) if args.truth else scoring.errors(nav, truth_states)
    return {**err, "t": err["t"] - initial_t_s}


def _replay(args) -> int:
    from hyper_nav_filter.sources import make_sources, parse_sources
    bag = pathlib.Path(args.bag)
    if not bag.exists():
        raise ScoringError(f"{bag}: no such bag")
    s = setup(args)
    inputs = {i.topic.lstrip("/") for src in make_sources(parse_sources(s.sources), s.config) for i in src.inputs()}
    sols, eng, truth_states, n_imu, error, truncated = _run(bag, s, inputs, args.smooth, not args.no_current)
    out = run_check.Outcome()
    if truncated:
        print(f"[replay_filter] WARNING: bag is truncated ({error}); replaying what was readable")
        out.failures.append(f"bag: truncated: {error}")
    if not sols:
        print("replay_filter: no solution (no IMU data after the initial epoch?)")
        return 1
    nav = scoring.states_from_solutions(sols)
    summary = None
    if s.scenario is not None and not args.truth:        # a run of a scenario: scored as report scores it
        if truth_states is None:
            raise ScoringError(f"{bag}: no truth/state in the bag: nothing to score against")
        _, summary = scoring.score(nav, truth_states, s.scenario, out)
    elif args.truth or truth_states is not None:
        summary = scoring.judge(_errors(nav, args, truth_states, s.initial.t_s), s.skip_s, s.limits, out)
    else:
        print("[replay_filter] no truth (--truth or truth/state in the bag): solution only")
    if summary is not None:
        print(scoring.format_table(summary, s.limits, s.reference))
    if s.scenario is not None:                          # what the live run's report checks of the fusion node
        if eng.counters["imu_accepted"] != n_imu:
            out.failures.append(f"inputs: imu/data_raw: {n_imu} in the bag, {eng.counters['imu_accepted']} "
                                f"accepted by the filter")
        run_check.rejected_inputs(dict(eng.counters), out)
        run_check.bridged_gaps(dict(eng.counters), out)
    ro = getattr(eng, "replay", None)
    if ro is not None:
        print(f"replay order: stamp order, {ro.placed} input(s) the live node received behind the IMU fed where it "
              f"received them" + (f"; {len(ro.missing)} reported late input(s) not in the bag" if ro.missing else ""))
    if args.smooth and summary is not None:
        from hyper_nav_filter.offline import smooth
        sm_nav = scoring.states_from_solutions(smooth(eng))
        sm = scoring.summarize(_errors(sm_nav, args, truth_states, s.initial.t_s), summary["skip_s"])
        print("fixed-interval RTS smoother over the same pass:")
        print(scoring.format_table(sm, s.limits, s.reference))
        print("filter vs smoother, RMS 3D: " + ", ".join(
            f"{k} {summary[k]['rms_3d']:.4g} -> {sm[k]['rms_3d']:.4g}" for k in scoring.ERROR_KEYS))
    if not args.no_current:
        _both_streams(bag, sols, eng.current_log or [], truth_states, s, out)
    _write_outputs(args, sols, nav, s)
    print(f"engine counters: {dict(eng.counters)}")
    noise_check.report_saved(bag / "noise_check.yaml", out)  # an import's IMU noise check (import_data)
    per_source = verdict_rules.from_filter(eng.kf)           # gated/accepted/NIS per source, and the rules
    print(verdict_rules.format_table(per_source))
    verdict_rules.check(per_source, out)
    return scoring.verdict(out, "replay_filter")


def stream_summary(sols, truth_states, layout, skip_s: float) -> dict | None:
    """A stream of solutions at its own stamps after ``skip_s``: position /
    velocity RMS 3D, mean position and velocity NEES (3 dof, its own
    covariance). The NEES of all epochs in one stacked solve (672,400
    current-time states: a solve per epoch took most of the command's time),
    the covariance blocks cut from each solution's P in one slice
    (``cov_blocks``), the attitude errors not formed (not used here)."""
    from hyper_nav_filter.core.fusion import solution_covariances
    sols = [x for x in sols if x.t_s >= skip_s]
    if not sols or truth_states is None:
        return None
    try:
        err, rows = scoring.errors(scoring.states_from_solutions(sols), truth_states, index=True, attitude=False)
    except ValueError:
        return None
    S_p, S_v = cov_blocks(solution_covariances([sols[i] for i in rows.tolist()]), layout.sl("pos"), layout.sl("vel"))
    ep, ev = err["pos_enu_m"], err["vel_enu_mps"]
    nees_p = _nees(S_p, ep)
    nees_v = _nees(S_v, ev)
    return {"epochs": len(err["t"]), "pos_rms_3d_m": float(np.sqrt(np.mean(np.sum(ep ** 2, axis=1)))),
            "vel_rms_3d_mps": float(np.sqrt(np.mean(np.sum(ev ** 2, axis=1)))),
            "nees_pos_mean": float(np.mean(nees_p)), "nees_vel_mean": float(np.mean(nees_v))}


def cov_blocks(Ps, *slices) -> list:
    """[P[sl, sl] of every P in Ps, stacked (n, k, k)] for each slice: one
    slice per matrix covering them all (the same numbers as a slice per block
    and matrix; peer-format set, 672,400 current-time covariances, position
    and velocity: 0.67 s -> 0.29 s, CPU, same process)."""
    if not len(Ps):
        return [np.zeros((0, sl.stop - sl.start, sl.stop - sl.start)) for sl in slices]
    lo, hi = min(sl.start for sl in slices), max(sl.stop for sl in slices)
    B = np.array([P[lo:hi, lo:hi] for P in Ps]).reshape(-1, hi - lo, hi - lo)
    return [np.ascontiguousarray(B[:, sl.start - lo:sl.stop - lo, sl.start - lo:sl.stop - lo]) for sl in slices]


def _nees(S: np.ndarray, e: np.ndarray) -> np.ndarray:
    """e_k^T S_k^-1 e_k of each row (S (n, 3, 3), e (n, 3))."""
    if not len(e):
        return np.zeros(0)
    return (e * np.linalg.solve(S, e[:, :, None])[:, :, 0]).sum(axis=1)     # the per-epoch e @ solve, bit for bit


def _equal(msgs, sols) -> tuple[int, int]:
    """(bit for bit, position bit for bit and velocity to 1e-12 m/s): how
    many recorded NavState messages equal the replayed solutions, in order
    (stamps to 1 us). The second count covers bags recorded by an older
    build whose velocity view rounded differently (1e-17 m/s)."""
    exact = close = 0
    for m, x in zip(msgs, sols):
        st = x.state
        if abs(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 - x.t_s) >= 1e-6 or \
                (m.lat_rad, m.lon_rad, m.alt_m) != (st.lat_rad, st.lon_rad, st.alt_m):
            continue
        dv = float(np.max(np.abs(np.asarray(m.vel_enu_mps, float) - st.vel_enu_mps)))
        exact += dv == 0.0
        close += dv <= 1e-12
    return exact, close


def _both_streams(bag, sols, current, truth_states, s: Setup, out) -> None:
    """Score the current-time stream beside the delayed one and, for a
    recording that has both (``nav/delayed/state``), compare each with the
    recorded stream bit for bit."""
    from hyper_nav_workbench.core.bag import deserialize, read_bag
    skip = s.skip_s if s.scenario is None else float(s.scenario["report.skip_s"])
    if s.scenario is not None:
        skip, _ = scoring.effective_skip_s(skip, float(s.scenario["duration_s"]))
    for name, stream in (("delayed (nav/delayed/state)", sols), ("current time (nav/state)", current)):
        sm = stream_summary(stream, truth_states, s.config.layout, skip)
        if sm is not None:
            print(f"{name}: {sm['epochs']} states after {skip:g} s: position RMS 3D {sm['pos_rms_3d_m']:.4g} m, "
                  f"velocity RMS 3D {sm['vel_rms_3d_mps']:.4g} m/s, mean NEES position {sm['nees_pos_mean']:.2f}, "
                  f"velocity {sm['nees_vel_mean']:.2f} (3 dof)")
            out.details["current_time" if stream is current else "delayed"] = sm
    topics = {"/nav/state": [], "/nav/delayed/state": []}
    recorded = {"/" + t.lstrip("/") for t in read_bag(bag).topics}
    if "/nav/delayed/state" in recorded:
        pairs = (("/nav/delayed/state", sols), ("/nav/state", current))
    elif "/nav/state" in recorded:               # a bag from before issue 35: nav/state was the released stream
        pairs = (("/nav/state", sols),)
    else:
        return                                  # an imported recording: nothing of a live node to compare with
    for r in read_bag(bag, topics=list(topics)):
        topics["/" + r.topic.lstrip("/")].append(deserialize(r.raw, r.msgtype))
    for topic, mine in pairs:
        rec = topics[topic]
        exact, same = _equal(rec, mine)
        print(f"{topic}: {exact} of {len(rec)} recorded states replayed bit for bit" +
              (f", {same} with the position bit for bit and the velocity to 1e-12 m/s" if same != exact else "") +
              f" ({len(mine)} replayed)")
        out.details[f"replayed_equal {topic}"] = {"bit_for_bit": exact, "equal": same, "recorded": len(rec),
                                                 "replayed": len(mine)}
        if same != len(rec) or len(mine) < len(rec):
            out.failures.append(f"replay: {topic}: {len(rec) - same} of {len(rec)} recorded states differ from the "
                                f"replay")


def _write_outputs(args, sols, nav: dict, s: Setup) -> None:
    """``--write-nav`` and ``--write-std`` (KF-GINS formats), one format operation per table."""
    from hyper_nav_workbench.core import array_io
    from hyper_nav_workbench.core.importer import kfgins
    if args.write_nav:
        # the closed form (C_b_n_to_euler's, bit for bit) over the stack: scipy's stack agrees to 1e-12 rad,
        # which moves the 9th decimal of 2 angles in 168,101 rows of the peer-format set; this writes the
        # per-message text
        rph = array_io.euler_rows(nav["C"])
        at = getattr(args, "write_nav_at", "imu")
        lat, lon, alt, vel = nav["lat"], nav["lon"], nav["alt"], nav["vel"]
        if at == "antenna":
            lat, lon, alt, vel = at_antenna(nav, np.array([s.omega_ib_b_radps for s in sols]).reshape(-1, 3),
                                            s.config.antenna_lever_arm_b_m)
        array_io.write_rows(args.write_nav, kfgins.nav_rows(nav["t"], lat, lon, alt, vel, rph))
        print(f"[replay_filter] wrote {args.write_nav} ({len(sols)} epochs, KF-GINS .nav, at the {at}"
              + (f", lever arm {list(s.config.antenna_lever_arm_b_m)} m body FLU" if at == "antenna" else "") + ")")
    if args.write_std:
        array_io.write_rows(args.write_std, kfgins.std_rows(nav["t"], sigma_blocks(sols, s.config.layout)))
        print(f"[replay_filter] wrote {args.write_std} ({len(sols)} epochs, KF-GINS STD)")


if __name__ == "__main__":
    sys.exit(main())


def at_antenna(nav: dict, omega_b_radps, lever_arm_b_m):
    """(lat, lon, alt, vel ENU) of the GNSS antenna from the IMU states:
    p_ant = p + C_b_n l_b (ENU offset on the ellipsoid's radii), v_ant = v +
    C_b_n (omega x l_b) (omega: the corrected body rate; earth rate neglected,
    7e-5 rad/s x the lever arm)."""
    from hyper_nav_gnss import earth
    lever = np.asarray(lever_arm_b_m, float)
    d_enu = np.einsum("nij,j->ni", nav["C"], lever)
    r_m, r_n = earth.radii(nav["lat"])
    lat = nav["lat"] + d_enu[:, 1] / (r_m + nav["alt"])
    lon = nav["lon"] + d_enu[:, 0] / ((r_n + nav["alt"]) * np.cos(nav["lat"]))
    alt = nav["alt"] + d_enu[:, 2]
    vel = nav["vel"] + np.einsum("nij,nj->ni", nav["C"], np.cross(omega_b_radps, lever))
    return lat, lon, alt, vel
