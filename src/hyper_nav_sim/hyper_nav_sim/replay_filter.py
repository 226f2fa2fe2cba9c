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
through the core (``hyper_nav_filter.offline.run_offline``); at the end of
the bag every solution is released, as the live node does at shutdown.
Progress (sim time, real-time factor, ETA) goes to stderr while the core
runs. Scoring (``core/scoring.py``): against ``--truth`` (any sampling,
interpolated to the solution epochs, ``core.importer.score``), else against
``truth/state`` in the bag. A scenario's replay is checked as its live run
is (every expected solution epoch scored, every IMU sample of the bag
accepted, no input rejected, no IMU gap bridged, the scenario's accuracy
limits); a replay of imported data against what its setup declares. Ends
with ``VERDICT: PASS`` or ``VERDICT: FAIL``; exit 0 (PASS), 1 (FAIL) or 2
(no replay possible: no such or unreadable bag, bad scenario or setup).
"""
from __future__ import annotations

import argparse
import pathlib
import sys
from dataclasses import dataclass

import numpy as np
import yaml

from hyper_nav_filter.core.params import ConfigError

from .core import run_check, scoring
from .core.scenario import ScenarioError, scenario_of_run
from .core.scoring import ScoringError


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
    ap.add_argument("--smooth", action="store_true",
                    help="also run the fixed-interval RTS smoother and print its errors next to the filter's")
    ap.add_argument("--filter", help="filter setup file (default: <bag>/filter.yaml, written by import_data)")
    ap.add_argument("--truth", help="truth file to score against (KF-GINS .nav layout unless --truth-map)")
    ap.add_argument("--truth-map", help="column map (YAML, core/importer/columns.py fields) of the --truth file")
    ap.add_argument("--write-nav", metavar="FILE", help="write the solution in the KF-GINS .nav format")
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
    from .core.importer import columns, kfgins
    path = pathlib.Path(args.truth)
    spec = yaml.safe_load(pathlib.Path(args.truth_map).read_text()) if args.truth_map else dict(kfgins.NAV)
    spec = {**spec, "file": str(path.resolve())}
    return columns.fix_table(spec, path.parent, "truth")


def sigma_blocks(sols, layout) -> dict:
    """{block: (n, 3) 1-sigma} of the 3-element blocks of the solutions' covariance (ENU convention)."""
    d = np.array([np.sqrt(np.maximum(np.diag(s.P), 0.0)) for s in sols])
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


def _run(records, s: Setup, keep_history: bool):
    """The fusion core over the records, with progress on stderr."""
    from hyper_nav_filter.offline import run_offline

    from .progress import Progress
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for _, m in records]
    t0, t1 = min(stamps), max(stamps)
    progress = Progress("replay_filter", total=t1 - t0)

    def fed():
        for k, rec in enumerate(records):
            if k % 2000 == 0:
                progress.update(stamps[k] - t0)
            yield rec
    sols, eng = run_offline(fed(), s.config, s.initial, sources=s.sources, final=True, keep_history=keep_history)
    progress.update(t1 - t0)
    progress.done(f"{len(sols)} solutions")
    return sols, eng


def _errors(nav: dict, args, truth_msgs, initial_t_s: float) -> dict:
    """Errors against the truth file or the bag's truth/state, timed from the
    initial epoch (``report.skip_s`` counts from it)."""
    from .core.importer import score
    err = score.errors_against(nav, truth_table(args)) if args.truth else \
        scoring.errors(nav, scoring.states_from_msgs(truth_msgs))
    return {**err, "t": err["t"] - initial_t_s}


def _replay(args) -> int:
    from hyper_nav_filter.replay_order import LATE_INPUTS_TOPIC
    from hyper_nav_filter.sources import make_sources, parse_sources

    from .core.bag import deserialize, read_bag
    bag = pathlib.Path(args.bag)
    if not bag.exists():
        raise ScoringError(f"{bag}: no such bag")
    s = setup(args)
    inputs = {i.topic.lstrip("/") for src in make_sources(parse_sources(s.sources), s.config) for i in src.inputs()}
    reader = read_bag(bag)
    # the fusion node's nav/late_inputs too: the replay feeds its own order (replay_order)
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in reader
               if r.topic.lstrip("/") in inputs | {"truth/state", LATE_INPUTS_TOPIC}]
    if not records:
        raise ScoringError(f"{bag}: no readable sensor messages" + (f" ({reader.error})" if reader.error else ""))
    out = run_check.Outcome()
    if reader.truncated:
        print(f"[replay_filter] WARNING: bag is truncated ({reader.error}); replaying what was readable")
        out.failures.append(f"bag: truncated: {reader.error}")
    sols, eng = _run(records, s, args.smooth)
    if not sols:
        print("replay_filter: no solution (no IMU data after the initial epoch?)")
        return 1
    nav = scoring.states_from_solutions(sols)
    truth_msgs = [m for t, m in records if t.lstrip("/") == "truth/state"]
    summary = None
    if s.scenario is not None and not args.truth:        # a run of a scenario: scored as report scores it
        _, summary = scoring.score(nav, scoring.states_from_msgs(truth_msgs), s.scenario, out)
    elif args.truth or truth_msgs:
        summary = scoring.judge(_errors(nav, args, truth_msgs, s.initial.t_s), s.skip_s, s.limits, out)
    else:
        print("[replay_filter] no truth (--truth or truth/state in the bag): solution only")
    if summary is not None:
        print(scoring.format_table(summary, s.limits, s.reference))
    if s.scenario is not None:                          # what the live run's report checks of the fusion node
        n_imu = sum(1 for t, _ in records if t.lstrip("/") == "imu/data_raw")
        if eng.counters["imu_accepted"] != n_imu:
            out.failures.append(f"inputs: imu/data_raw: {n_imu} in the bag, {eng.counters['imu_accepted']} "
                                f"accepted by the filter")
        run_check.rejected_inputs(dict(eng.counters), out)
        run_check.bridged_gaps(dict(eng.counters), out)
    ro = eng.replay
    print(f"replay order: stamp order, {ro.placed} input(s) the live node received behind the IMU fed where it "
          f"received them" + (f"; {len(ro.missing)} reported late input(s) not in the bag" if ro.missing else ""))
    if args.smooth and summary is not None:
        from hyper_nav_filter.offline import smooth
        sm_nav = scoring.states_from_solutions(smooth(eng))
        sm = scoring.summarize(_errors(sm_nav, args, truth_msgs, s.initial.t_s), summary["skip_s"])
        print("fixed-interval RTS smoother over the same pass:")
        print(scoring.format_table(sm, s.limits, s.reference))
        print("filter vs smoother, RMS 3D: " + ", ".join(
            f"{k} {summary[k]['rms_3d']:.4g} -> {sm[k]['rms_3d']:.4g}" for k in scoring.ERROR_KEYS))
    _write_outputs(args, sols, nav, s)
    print(f"engine counters: {dict(eng.counters)}")
    return scoring.verdict(out, "replay_filter")


def _write_outputs(args, sols, nav: dict, s: Setup) -> None:
    """``--write-nav`` and ``--write-std`` (KF-GINS formats)."""
    from hyper_nav_filter.core.attitude import C_b_n_to_euler

    from .core.importer import kfgins
    if args.write_nav:
        rph = np.array([C_b_n_to_euler(x.state.C_b_n) for x in sols])
        kfgins.write_rows(args.write_nav, kfgins.nav_rows(nav["t"], nav["lat"], nav["lon"], nav["alt"], nav["vel"], rph))
        print(f"[replay_filter] wrote {args.write_nav} ({len(sols)} epochs, KF-GINS .nav)")
    if args.write_std:
        kfgins.write_rows(args.write_std, kfgins.std_rows(nav["t"], sigma_blocks(sols, s.config.layout)))
        print(f"[replay_filter] wrote {args.write_std} ({len(sols)} epochs, KF-GINS STD)")


if __name__ == "__main__":
    sys.exit(main())
