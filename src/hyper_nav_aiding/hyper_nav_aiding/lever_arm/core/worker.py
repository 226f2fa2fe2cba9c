"""The re-estimation worker: a persistent child process (``spawn``) that runs
``reestimate`` jobs off the node's callback thread. The node submits a job and
polls; a job that outlives its wall-time limit (plus ``grace_s``, counted from
when the process is ready: starting it and importing the numeric stack can
take a minute on a loaded machine) is abandoned:
the process is terminated and a fresh one started, and the poll reports the
timeout, so the caller keeps the model in force. The process imports the
numeric stack and compiles the DDPG networks once at start (``warm_up``)."""
from __future__ import annotations

import multiprocessing as mp
import os
import queue
import time
import traceback
from dataclasses import dataclass


def _serve(jobs, results, warm_up: bool, nice: int) -> None:
    if nice:
        os.nice(nice)
    from hyper_nav_aiding.lever_arm.core.reestimate import reestimate
    if warm_up:
        from hyper_nav_aiding.lever_arm.core import ddpg
        c = ddpg.DDPGConfig()
        import numpy as np
        init, act, update = ddpg._functions(c.hidden, c.actor_lr, c.critic_lr, c.gamma, c.tau)
        p = init(0)
        act(p["actor"], np.zeros((1, 3), np.float32))
        z = np.zeros((c.batch, 3), np.float32)
        update(p, z, z, np.zeros(c.batch, np.float32), z, np.zeros(c.batch, np.float32))
    results.put(("ready", None, None))
    while True:
        job = jobs.get()
        if job is None:
            return
        job_id, fn_name, args = job
        try:
            fn = {"reestimate": reestimate}[fn_name]
            results.put(("ok", job_id, fn(*args)))
        except Exception:                                  # reported to the node, never raised there
            results.put(("error", job_id, traceback.format_exc(limit=5)))


@dataclass
class JobOutcome:
    job_id: int
    status: str          # "ok", "error" or "timeout"
    value: object        # the result, the traceback text or the elapsed seconds
    wall_s: float


class ReestimationWorker:
    def __init__(self, warm_up: bool = True, grace_s: float = 5.0, nice: int = 10):
        self._ctx = mp.get_context("spawn")
        self.warm_up = warm_up
        self.nice = nice
        self.grace_s = grace_s
        self._proc = None
        self._running: dict | None = None      # {"id", "t0", "limit"}
        self._next_id = 0
        self.ready = False
        self.n_restarts = 0
        self._start()

    def _start(self) -> None:
        self._jobs, self._results = self._ctx.Queue(), self._ctx.Queue()
        self._proc = self._ctx.Process(target=_serve, args=(self._jobs, self._results, self.warm_up, self.nice),
                                       daemon=True)
        self._proc.start()
        self.ready = False

    @property
    def busy(self) -> bool:
        return self._running is not None

    def submit(self, args: tuple, timeout_s: float) -> int:
        """Queue ``reestimate(*args)``; one job at a time."""
        if self.busy:
            raise RuntimeError("a re-estimation is already running")
        self._next_id += 1
        self._running = {"id": self._next_id, "t0": time.monotonic(), "limit": timeout_s}
        self._jobs.put((self._next_id, "reestimate", args))
        return self._next_id

    def poll(self) -> JobOutcome | None:
        """Non-blocking: the outcome of the running job once it is over."""
        while True:
            try:
                status, job_id, value = self._results.get_nowait()
            except queue.Empty:
                break
            if status == "ready":
                self.ready = True
                if self._running is not None:       # the limit counts the job, not the process start
                    self._running["t0"] = time.monotonic()
                continue
            if self._running is not None and job_id == self._running["id"]:
                wall = time.monotonic() - self._running["t0"]
                self._running = None
                return JobOutcome(job_id, status, value, wall)
        if self._running is not None:
            elapsed = time.monotonic() - self._running["t0"]
            late = self.ready and elapsed > self._running["limit"] + self.grace_s
            if late or not self._proc.is_alive():
                job_id = self._running["id"]
                self._running = None
                status = "timeout" if self._proc.is_alive() else "error"
                value = elapsed if status == "timeout" else f"worker process died (exit code {self._proc.exitcode})"
                self._restart()
                return JobOutcome(job_id, status, value, elapsed)
        return None

    def _restart(self) -> None:
        self._proc.terminate()
        self._proc.join(timeout=5.0)
        if self._proc.is_alive():
            self._proc.kill()
            self._proc.join(timeout=5.0)
        self.n_restarts += 1
        self._start()

    def close(self) -> None:
        if self._proc is not None and self._proc.is_alive():
            try:
                self._jobs.put(None)
                self._proc.join(timeout=2.0)
            finally:
                if self._proc.is_alive():
                    self._proc.terminate()
                    self._proc.join(timeout=2.0)
