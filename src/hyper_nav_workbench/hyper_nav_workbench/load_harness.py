"""A reproducible load beside a node graph (issue 33): CPU-bound processes at
normal priority, the graph squeezed onto fewer cores, a node frozen
(SIGSTOP) for a while and resumed, or throttled to a fraction of a CPU.

A graph on a loaded machine must lose nothing: the clock gate
(``hyper_nav_filter.clock_gate``) slows the flight down instead. These tools
make the load that would otherwise come from a busy CI machine, on purpose
and the same every time:

* ``BusyProcesses(n)``: ``n`` processes ``python -c 'while True: pass'`` at
  nice 0 (optionally pinned to cores), stopped on exit;
* ``pin(pid, cores)``: a process and its threads onto these cores
  (``taskset``; children started later inherit it);
* ``freeze(pid, s)``: SIGSTOP, ``s`` s of wall time, SIGCONT;
* ``Throttle(pid, duty)``: the process runs ``duty`` of each 50 ms period
  and is stopped for the rest (as ``cpulimit`` does): a node starved of
  CPU while the others are not, the case where its own queues fill.

``freeze_each`` freezes every node of a running graph in turn. The
``load_flight`` command runs ``run_graph`` under all of it (``make
load-run``) and passes its report's verdict through: PASS only when
published == recorded == received == processed for every topic.
"""
from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import threading
import time

BUSY_CODE = "while True: pass"


def _normal_priority() -> None:
    """nice 0 whatever the caller's (a test lane may run at nice 19); unprivileged: keep the caller's."""
    try:
        os.setpriority(os.PRIO_PROCESS, 0, 0)
    except PermissionError:
        pass


class BusyProcesses:
    """``n`` CPU-bound Python processes at normal priority (nice 0), each
    pinned to ``cores`` when given. A context manager; ``stop()`` kills them."""

    def __init__(self, n: int, cores=None):
        self.n = int(n)
        self.cores = None if cores is None else set(cores)
        self.procs: list[subprocess.Popen] = []

    def start(self) -> "BusyProcesses":
        for _ in range(self.n):
            p = subprocess.Popen([sys.executable, "-c", BUSY_CODE], stdin=subprocess.DEVNULL,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                 preexec_fn=_normal_priority)
            if self.cores:
                os.sched_setaffinity(p.pid, self.cores)
            self.procs.append(p)
        return self

    @property
    def pids(self) -> list[int]:
        return [p.pid for p in self.procs]

    def stop(self) -> None:
        for p in self.procs:
            if p.poll() is None:
                p.kill()
        for p in self.procs:
            p.wait()
        self.procs = []

    def __enter__(self) -> "BusyProcesses":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def pin(pid: int, cores) -> None:
    """Restrict a process (all its threads) to ``cores``."""
    cores = set(cores)
    for task in pathlib.Path(f"/proc/{pid}/task").iterdir():
        try:
            os.sched_setaffinity(int(task.name), cores)
        except (ProcessLookupError, PermissionError):
            pass


def parse_cores(text: str) -> set[int]:
    """``"0"``, ``"0,1"``, ``"0-3"`` -> a set of core numbers (taskset's list form)."""
    out = set()
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        a, _, b = part.partition("-")
        out.update(range(int(a), int(b or a) + 1))
    if not out:
        raise ValueError(f"no cores in {text!r}")
    bad = out - set(range(os.cpu_count() or 1))
    if bad:
        raise ValueError(f"cores {sorted(bad)} do not exist (this machine has {os.cpu_count()})")
    return out


def freeze(pid: int, seconds: float, release: threading.Event | None = None) -> float:
    """SIGSTOP ``pid``, wait ``seconds`` of wall time (or until ``release`` is
    set, if sooner), SIGCONT it. Returns the wall time it was stopped (s); a
    process that exited meanwhile is not an error."""
    t0 = time.monotonic()
    try:
        os.kill(pid, signal.SIGSTOP)
    except ProcessLookupError:
        return 0.0
    try:
        if release is None:
            time.sleep(seconds)
        else:
            release.wait(seconds)
    finally:
        try:
            os.kill(pid, signal.SIGCONT)
        except ProcessLookupError:
            pass
    return time.monotonic() - t0


class Throttle:
    """Let ``pid`` run ``duty`` (0..1) of every ``period_s`` and keep it
    stopped for the rest, from a background thread, until ``stop()`` (which
    always leaves it running)."""

    def __init__(self, pid: int, duty: float, period_s: float = 0.05):
        if not 0.0 < duty <= 1.0:
            raise ValueError(f"duty: in (0, 1], got {duty}")
        self.pid, self.duty, self.period_s = pid, float(duty), float(period_s)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        run_s, stop_s = self.duty * self.period_s, (1.0 - self.duty) * self.period_s
        try:
            while not self._stop.is_set():
                os.kill(self.pid, signal.SIGSTOP)
                self._stop.wait(stop_s)
                os.kill(self.pid, signal.SIGCONT)
                self._stop.wait(run_s)
        except ProcessLookupError:
            pass
        finally:
            try:
                os.kill(self.pid, signal.SIGCONT)
            except ProcessLookupError:
                pass

    def start(self) -> "Throttle":
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()

    def __enter__(self) -> "Throttle":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def freeze_each(pids: dict[str, int], freeze_s: float, gap_s: float = 2.0, order=None,
                alive=lambda: True, log=print) -> list[dict]:
    """Freeze every node of ``pids`` (name -> pid) in turn for ``freeze_s``
    s, ``gap_s`` s apart, while ``alive()``. Returns what was done:
    [{"node", "pid", "frozen_s", "t_wall_s"}]."""
    done, t0 = [], time.monotonic()
    for name in order or sorted(pids):
        if not alive():
            break
        pid = pids[name]
        log(f"[load] freezing {name} (pid {pid}) for {freeze_s:g} s")
        t = time.monotonic() - t0
        held = freeze(pid, freeze_s)
        done.append({"node": name, "pid": pid, "frozen_s": round(held, 2), "t_wall_s": round(t, 2)})
        time.sleep(gap_s)
    return done


# ---- load_flight: run_graph under load -------------------------------------------------------
def graph_children(parent_pid: int) -> dict[str, int]:
    """Node name -> pid of a ``run_graph`` process's node processes (/proc;
    the node started through ``setpriv`` is the same process after exec)."""
    from hyper_nav_workbench.graph import executables
    by_exe = {exe: name for name, (_pkg, exe) in executables().items()}
    out = {}
    for stat in pathlib.Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[1]) != parent_pid:
                continue
            cmd = [c.decode(errors="replace") for c in (stat.parent / "cmdline").read_bytes().split(b"\0")]
        except (OSError, IndexError, ValueError):
            continue
        for part in cmd:
            name = by_exe.get(os.path.basename(part))
            if name and "/lib/" in part:
                out[name] = int(stat.parent.name)
    return out


def _wait_flying(proc: subprocess.Popen, out_path: pathlib.Path, record: str, timeout_s: float) -> bool:
    """Wait until the time source of ``run_graph`` (its stdout in
    ``out_path``, its bag ``record``) says the flight or replay runs."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        bag = record
        for line in out_path.read_text(errors="replace").splitlines():
            if " exists; recording to " in line:          # run_graph's new name for an existing bag
                bag = line.rsplit(" ", 1)[1]
        logs = pathlib.Path(bag).with_name(pathlib.Path(bag).name + "_logs")
        for src, word in (("truth", "flying"), ("player", "replaying")):
            log = logs / f"{src}.log"
            if log.is_file() and word in log.read_text(errors="replace"):
                return True
        time.sleep(0.2)
    return False


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(
        prog="load_flight", description="Fly run_graph under a reproducible load: CPU-bound processes at "
        "normal priority beside it, the graph on fewer cores, each node frozen (SIGSTOP) in turn. Its exit code "
        "is run_graph's (with --report: 0 only when the report passes, i.e. nothing was lost).",
        epilog="example: load_flight --busy 2 --cores 0 --freeze-each 5 -- --scenario seed000_elastic "
        "--record bags/load --report")
    ap.add_argument("--busy", type=int, default=len(os.sched_getaffinity(0)),
                    help="CPU-bound processes (nice 0) beside the graph (default: one per core)")
    ap.add_argument("--cores", default=None, help="run the graph on these cores only (taskset list, e.g. 0)")
    ap.add_argument("--freeze-each", type=float, default=0.0, metavar="S",
                    help="freeze every node in turn for S s of wall time (SIGSTOP, then SIGCONT)")
    ap.add_argument("--nodes", default=None, help="comma-separated nodes to freeze (default: every node, "
                    "the recorder and the monitor included)")
    ap.add_argument("--gap", type=float, default=2.0, help="wall s between two freezes")
    ap.add_argument("--start-timeout", type=float, default=180.0, help="wall s to wait for the flight to start")
    ap.add_argument("graph_args", nargs=argparse.REMAINDER, help="-- then run_graph's arguments")
    args = ap.parse_args(argv)
    graph_args = args.graph_args[1:] if args.graph_args[:1] == ["--"] else args.graph_args
    if args.freeze_each and "--record" not in graph_args[:-1]:
        ap.error("--freeze-each needs run_graph's --record (the nodes' logs say when the flight runs)")
    cores = parse_cores(args.cores) if args.cores else None
    record = graph_args[graph_args.index("--record") + 1] if "--record" in graph_args[:-1] else None
    from ament_index_python.packages import get_package_prefix
    exe = pathlib.Path(get_package_prefix("hyper_nav_workbench")) / "lib" / "hyper_nav_workbench" / "run_graph"
    import tempfile
    out_path = pathlib.Path(tempfile.mkstemp(prefix="load_flight_", suffix=".out")[1])
    print(f"[load] {args.busy} busy process(es) at nice 0 beside the graph"
          + (f"; graph on core(s) {sorted(cores)}" if cores else "")
          + (f"; each node frozen {args.freeze_each:g} s in turn" if args.freeze_each else ""), flush=True)
    done = []
    with BusyProcesses(args.busy):
        with out_path.open("w") as out:
            proc = subprocess.Popen([str(exe), *graph_args], stdout=out, stderr=subprocess.STDOUT,
                                    preexec_fn=(lambda: os.sched_setaffinity(0, cores)) if cores else None)
        tail = _Tail(out_path)
        try:
            if args.freeze_each:
                flying = _wait_flying(proc, out_path, record, args.start_timeout)
                tail.flush()
                if not flying:
                    print("[load] the flight did not start; nothing frozen", flush=True)
                else:
                    pids = graph_children(proc.pid)
                    wanted = args.nodes.split(",") if args.nodes else sorted(pids)
                    unknown = [n for n in wanted if n not in pids]
                    if unknown:
                        print(f"[load] not running, not frozen: {', '.join(unknown)}", flush=True)
                    done = freeze_each({n: pids[n] for n in wanted if n in pids}, args.freeze_each, args.gap,
                                       alive=lambda: proc.poll() is None,
                                       log=lambda s: (tail.flush(), print(s, flush=True)))
            while proc.poll() is None:
                tail.flush()
                time.sleep(0.5)
        except KeyboardInterrupt:
            proc.send_signal(signal.SIGINT)
            proc.wait()
        finally:
            for pid in graph_children(proc.pid).values() if proc.poll() is None else ():
                try:
                    os.kill(pid, signal.SIGCONT)           # never leave a node stopped
                except ProcessLookupError:
                    pass
        tail.flush()
    out_path.unlink(missing_ok=True)
    frozen = ", ".join(f"{d['node']} {d['frozen_s']:.1f} s" for d in done)
    print(f"[load] frozen in turn: {frozen or 'none'}; run_graph exit code {proc.returncode}", flush=True)
    return proc.returncode


class _Tail:
    """Echo a growing file's new lines."""

    def __init__(self, path: pathlib.Path):
        self.path, self.pos = path, 0

    def flush(self) -> None:
        with self.path.open("rb") as f:
            f.seek(self.pos)
            data = f.read()
        cut = data.rfind(b"\n") + 1
        if cut:
            sys.stdout.write(data[:cut].decode(errors="replace"))
            sys.stdout.flush()
            self.pos += cut


if __name__ == "__main__":
    sys.exit(main())
