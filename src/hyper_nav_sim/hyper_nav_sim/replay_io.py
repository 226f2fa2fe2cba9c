"""``replay_filter`` on data from outside the project (options added to the
command by ``report.py``):

    replay_filter bags/my_drive                          # the bag's filter.yaml (import_data) sets the filter
    replay_filter bags/my_drive --truth truth.nav        # score against a truth file (KF-GINS .nav layout)
    replay_filter bags/my_drive --write-nav out.nav --write-std out_std.txt   # KF-GINS formats

The filter comes from ``--filter FILE``, else ``<bag>/filter.yaml``, else
the scenario (``--scenario``, as before). Scoring: against ``--truth`` (any
sampling; interpolated to the solution epochs, ``core.importer.score``),
else against ``truth/state`` in the bag. Progress (sim time, real-time
factor, ETA) goes to stderr while the core runs.
"""
from __future__ import annotations

import pathlib

import numpy as np
import yaml

from hyper_nav_filter.core.params import ConfigError


def add_arguments(ap) -> None:
    ap.add_argument("--filter", help="filter setup file (default: <bag>/filter.yaml, written by import_data)")
    ap.add_argument("--truth", help="truth file to score against (KF-GINS .nav layout unless --truth-map)")
    ap.add_argument("--truth-map", help="column map (YAML, core/importer/columns.py fields) of the --truth file")
    ap.add_argument("--write-nav", metavar="FILE", help="write the solution in the KF-GINS .nav format")
    ap.add_argument("--write-std", metavar="FILE", help="write the standard deviations in the KF-GINS STD format")


def handles(args) -> bool:
    """True when the options of this module are in use (or the bag was imported)."""
    return bool(args.filter or args.truth or args.write_nav or args.write_std
                or (pathlib.Path(args.bag) / "filter.yaml").exists())


def _setup(args):
    """(config, initial state, sources table, skip_s, limits, reference, name)."""
    from hyper_nav_filter.filter_setup import FilterSetup

    from . import report
    path = pathlib.Path(args.filter) if args.filter else pathlib.Path(args.bag) / "filter.yaml"
    if args.filter or path.exists():
        s = FilterSetup.load(path)
        return s.config, s.initial, s.sources, s.skip_s, {}, {}, path.parent.name
    sc = report._scenario(args)
    return (sc.filter_config(), sc.filter_initial_state(), sc.filter_sources(), sc["report.skip_s"],
            report._limits(sc), report._reference(sc), sc.name)


def _truth_table(args):
    from .core.importer import columns, kfgins
    path = pathlib.Path(args.truth)
    spec = yaml.safe_load(pathlib.Path(args.truth_map).read_text()) if args.truth_map else dict(kfgins.NAV)
    spec = {**spec, "file": str(path.resolve())}
    return columns.fix_table(spec, path.parent, "truth")


def sigma_blocks(sols, layout) -> dict:
    """{block: (n, 3) 1-sigma} of the 3-element blocks of the solutions' covariance (ENU convention)."""
    d = np.array([np.sqrt(np.maximum(np.diag(s.P), 0.0)) for s in sols])
    return {name: d[:, layout.sl(name)] for name in layout.names if layout.sl(name).stop - layout.sl(name).start == 3}


def main(args) -> int:
    """The replay on arrays: the bag read into field arrays (``core/bag_arrays``),
    the core fed from them (``hyper_nav_filter.offline_arrays``: the results of
    ``run_offline``, bit for bit), scored and written one array operation per
    quantity (``core/fast_scoring``)."""
    from hyper_nav_filter.core.attitude import C_b_n_to_euler
    from hyper_nav_filter.offline_arrays import run_offline_arrays
    from hyper_nav_filter.replay_order import LATE_INPUTS_TOPIC

    from . import report
    from .core import fast_scoring
    from .core.bag_arrays import read_arrays
    from .core.importer import kfgins
    from .progress import Progress
    try:
        cfg, initial, sources, skip_s, limits, reference, _ = _setup(args)
        initial_t_s = initial.t_s
    except ConfigError as exc:
        print(f"replay_filter: error: {exc}", flush=True)
        return 2
    from hyper_nav_filter.sources import make_sources, parse_sources
    inputs = {i.topic.lstrip("/") for src in make_sources(parse_sources(sources), cfg) for i in src.inputs()}
    bag = read_arrays(args.bag)
    topics = [t for name, t in bag.topics.items() if name.lstrip("/") in inputs]
    truth_topic = next((t for name, t in bag.topics.items() if name.lstrip("/") == "truth/state"), None)
    late = next((t for name, t in bag.topics.items() if name.lstrip("/") == LATE_INPUTS_TOPIC), None)
    if bag.truncated:
        print(f"[replay_filter] WARNING: bag is truncated ({bag.error}); replaying what was readable")
    stamps = [t.stamp_s for t in topics + ([truth_topic] if truth_topic is not None else []) if len(t)]
    t0, t1 = (min(float(s.min()) for s in stamps), max(float(s.max()) for s in stamps)) if stamps else (0.0, 0.0)
    progress = Progress("replay_filter", total=t1 - t0)
    n_fed = sum(len(t) for t in topics)
    if late is not None and len(late):
        # a recording of a live node that received inputs behind the IMU: the replay feeds the node's own
        # order (hyper_nav_filter.replay_order, its nav/late_inputs reports) on the per-message path
        from hyper_nav_filter.offline import run_offline
        from .core.bag import deserialize, read_bag
        records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(args.bag)
                   if r.topic.lstrip("/") in inputs | {LATE_INPUTS_TOPIC}]
        sols, eng = run_offline(records, cfg, initial, sources=sources, final=True, keep_history=args.smooth)
    else:                                   # stamp order (no input came late): the arrays
        sols, eng, _ = run_offline_arrays(topics, cfg, initial, sources=sources, final=True,
                                          keep_history=args.smooth,
                                          progress=lambda k: progress.update((t1 - t0) * k / max(n_fed, 1)))
    progress.update(t1 - t0)
    progress.done(f"{len(sols)} solutions")
    if not sols:
        print("replay_filter: no solution (no IMU data after the initial epoch?)")
        return 1
    nav = report.states_from_solutions(sols)
    has_truth = truth_topic is not None and len(truth_topic) > 0
    summary = None
    truth_table = _truth_table(args) if args.truth else None
    truth_states = fast_scoring.states_from_topic(truth_topic) if has_truth and not args.truth else None
    if args.truth:
        err = fast_scoring.errors_against(nav, truth_table)
    elif has_truth:
        err = fast_scoring.errors(nav, truth_states)
    else:
        err = None
        print("[replay_filter] no truth (--truth or truth/state in the bag): solution only")
    if err is not None:
        err = {**err, "t": err["t"] - initial_t_s}        # report.skip_s counts from the initial epoch
        summary = report.summarize(err, skip_s)
        print(report.format_table(summary, limits, reference))
    if args.smooth and (args.truth or has_truth):
        from hyper_nav_filter.offline import smooth
        sm_nav = report.states_from_solutions(smooth(eng))
        sm_err = fast_scoring.errors_against(sm_nav, truth_table) if args.truth else \
            fast_scoring.errors(sm_nav, truth_states)
        print("fixed-interval RTS smoother over the same pass:")
        sm_err = {**sm_err, "t": sm_err["t"] - initial_t_s}
        print(report.format_table(report.summarize(sm_err, skip_s), limits, reference))
    if args.write_nav:
        # the closed form per matrix (2 us each): scipy's stack agrees to 1e-12 rad, which moves the 9th
        # decimal of 2 angles in 168,101 rows of the peer-format set; this writes the per-message text
        rph = np.array([C_b_n_to_euler(C) for C in nav["C"]])
        fast_scoring.write_rows(args.write_nav, kfgins.nav_rows(nav["t"], nav["lat"], nav["lon"], nav["alt"],
                                                                nav["vel"], rph))
        print(f"[replay_filter] wrote {args.write_nav} ({len(sols)} epochs, KF-GINS .nav)")
    if args.write_std:
        fast_scoring.write_rows(args.write_std, kfgins.std_rows(nav["t"], sigma_blocks(sols, cfg.layout)))
        print(f"[replay_filter] wrote {args.write_std} ({len(sols)} epochs, KF-GINS STD)")
    print(f"engine counters: {dict(eng.counters)}")
    return 0
