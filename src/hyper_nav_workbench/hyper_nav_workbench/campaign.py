"""One campaign engine on dask.distributed: the runs of a Monte Carlo
campaign or of a paper reproduction (one run per seed, or per seed and
world) go to a ``LocalCluster`` on this machine or to an existing cluster
(``--scheduler tcp://host:port``), with one progress line, the per-run JSON
files and results in run order, whatever the number of workers.

    from hyper_nav_workbench import campaign
    campaign.add_arguments(ap)                       # --workers, --scheduler, --max-workers
    res = campaign.run("repro_seed003", run_seed, jobs, keys=[f"seed{j.seed:03d}" for j in jobs],
                       options=campaign.options(args), out_dir=out / "runs")
    res.results                                      # in the order of ``jobs``

A run is a module-level function of one picklable job; it must draw every
random number from the job (its seed), never from the worker: the results
are then the same on 1 or N workers (tested for every reproduction). The
cluster: one single-threaded worker process per core by default (or
``workers``), bound to 127.0.0.1, no dashboard; with ``scheduler`` nothing
is started and ``max_workers`` keeps the campaign to that many of the
cluster's workers. Every worker imports ``warm_up`` modules at once before
the first run (otherwise the first run of each worker pays for them alone).
No rclpy.
"""
from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import importlib
import json
import os
import pathlib
import time
from typing import Callable, Sequence

from hyper_nav_workbench.progress import Progress


@dataclasses.dataclass(frozen=True)
class Options:
    workers: int | None = None          # LocalCluster size (default: one per core)
    scheduler: str | None = None        # address of an existing scheduler
    max_workers: int | None = None      # use at most this many of the cluster's workers


def add_arguments(ap, default_workers: int | None = None) -> None:
    """``--workers``, ``--scheduler``, ``--max-workers`` on a command line."""
    ap.add_argument("--workers", type=int, default=default_workers,
                    help="LocalCluster worker processes (default: one per core)")
    ap.add_argument("--scheduler", default=None, help="address of an existing dask scheduler (tcp://host:port)")
    ap.add_argument("--max-workers", type=int, default=None, help="use at most this many of the cluster's workers")


def options(args) -> Options:
    return Options(getattr(args, "workers", None), getattr(args, "scheduler", None), getattr(args, "max_workers", None))


def where(opts: Options) -> str:
    """What the campaign runs on, for the command's first line."""
    return opts.scheduler or f"LocalCluster, {opts.workers or os.cpu_count()} worker(s)"


@dataclasses.dataclass
class Result:
    results: list                # in the order of the jobs
    workers: int
    wall_s: float                # from the cluster being up to the last result (worker imports included)
    runs_per_min: float
    cpu_s: float | None          # summed ``cpu_s`` of the results, when the runs report it


def _import_all(modules: tuple) -> bool:
    for m in modules:
        importlib.import_module(m)
    return True


def _timed(fn: Callable, job):
    """Run one job on a worker; (result, process CPU seconds)."""
    t0 = time.process_time()
    out = fn(job)
    return out, time.process_time() - t0


def new_local_cluster(n_workers: int):
    """The campaign's local cluster: ``n_workers`` single-threaded worker
    processes bound to 127.0.0.1, no dashboard."""
    from dask.distributed import LocalCluster
    return LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                        dashboard_address=None, silence_logs=40)


@contextlib.contextmanager
def local_cluster(n_workers: int, log: Callable = print):
    """``with local_cluster(2) as cluster:`` a ``new_local_cluster`` closed
    as ``run`` closes its own (a late worker reaping is reported, not raised)."""
    cluster = new_local_cluster(n_workers)
    try:
        yield cluster
    finally:
        _close_cluster(cluster, log)


def _close_cluster(cluster, log: Callable) -> None:
    try:
        cluster.close()
    except (TimeoutError, asyncio.TimeoutError) as exc:   # noqa: B014 (distinct before 3.11)
        log(f"campaign: local cluster shutdown timed out ({type(exc).__name__}); "
            "its worker processes were killed, all results are in")


def _shut_down(client, cluster, log: Callable) -> None:
    """Close the client and a local cluster. Results are already in when this
    runs, so a slow shutdown must not lose them: on a loaded machine a
    nanny's worker process can take longer to be reaped after its SIGKILL
    than dask's fixed 5 s nanny close allows (a CI run failed on that
    ``TimeoutError`` after the campaign had finished). The timeout is
    reported and the run's results are kept; the nanny has already killed
    the worker."""
    try:
        client.close()
    finally:
        if cluster is not None:
            _close_cluster(cluster, log)


def run(label: str, fn: Callable, jobs: Sequence, keys: Sequence[str] | None = None, opts: Options = Options(),
        out_dir=None, to_json: Callable | None = None, warm_up: tuple = (), progress: bool = True,
        log: Callable = print) -> Result:
    """Run ``fn(job)`` for every job on dask (see the module docstring).
    ``out_dir``: each run's result as ``<out_dir>/<key>.json`` (through
    ``to_json``, default the result itself) as soon as it is in."""
    from dask.distributed import Client, as_completed
    keys = list(keys) if keys is not None else [f"run{k:04d}" for k in range(len(jobs))]
    if len(keys) != len(jobs) or len(set(keys)) != len(keys):
        raise ValueError("campaign: one distinct key per job")
    out_dir = pathlib.Path(out_dir) if out_dir is not None else None
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
    cluster = None
    if opts.scheduler:
        client = Client(opts.scheduler)
    else:
        n = opts.workers or os.cpu_count() or 1
        cluster = new_local_cluster(n)
        client = Client(cluster)
    bar = Progress(label, total=len(jobs), unit="runs", sim=False, interval_s=5.0) if progress else None
    t0 = time.monotonic()
    results: list = [None] * len(jobs)
    cpu = []
    try:
        allowed = sorted(client.scheduler_info()["workers"])[:opts.max_workers] if opts.max_workers else None
        n_workers = len(allowed) if allowed else len(client.scheduler_info()["workers"])
        if warm_up:
            client.run(_import_all, tuple(warm_up), workers=allowed)
        futures = {client.submit(_timed, fn, job, pure=False, workers=allowed, key=f"{label}-{key}-{os.getpid()}"): i
                   for i, (job, key) in enumerate(zip(jobs, keys))}
        done = 0
        for fut in as_completed(futures):
            i = futures[fut]
            results[i], c = fut.result()
            cpu.append(c)
            done += 1
            if out_dir is not None:
                doc = to_json(results[i]) if to_json is not None else results[i]
                (out_dir / f"{keys[i]}.json").write_text(json.dumps(jsonable(doc), indent=1))
            if bar is not None:
                bar.update(done)
    finally:
        _shut_down(client, cluster, log)
    wall = time.monotonic() - t0
    res = Result(results, n_workers, wall, 60.0 * len(jobs) / wall if wall > 0 else float("inf"), float(sum(cpu)))
    if bar is not None:
        bar.done(f"{res.runs_per_min:.1f} runs/min on {n_workers} worker(s), "
                 f"{res.cpu_s / max(len(jobs), 1):.1f} CPU s per run, {res.cpu_s / max(wall, 1e-9):.2f} cores used")
    return res


def jsonable(x):
    """Plain JSON types (numpy arrays and scalars, tuples, dataclasses; non-finite floats -> None)."""
    import math

    import numpy as np
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return jsonable({f.name: getattr(x, f.name) for f in dataclasses.fields(x)})
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, np.generic):
        return jsonable(x.item())
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x
