"""Re-estimation job and worker process (core.lever_arm.reestimate,
core.lever_arm.worker): a job that raises or outlives its limit is reported,
never raised, and the worker is ready again afterwards."""
import dataclasses
import time

import numpy as np
from hyper_nav_filter.core.elastic_lever_arm import TABLE2_FREQ_RADPS

INITIAL = np.asarray(TABLE2_FREQ_RADPS)

from hyper_nav_aiding.lever_arm.core.reestimate import ReestimationConfig, reestimate
from hyper_nav_aiding.lever_arm.core.worker import ReestimationWorker


def wait(worker, timeout_s=600.0):
    """The worker's next outcome; the bound only guards against a hang (a loaded
    machine may take a minute to spawn the process and import the numeric stack)."""
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        out = worker.poll()
        if out is not None:
            return out
        time.sleep(0.05)
    raise TimeoutError


def test_failed_and_timed_out_jobs_are_reported(doublet, pm_window):
    _, cfg, _ = doublet
    w = ReestimationWorker(warm_up=False, grace_s=0.5, nice=0)
    try:
        bad = dataclasses.replace(pm_window, gnss=())
        w.submit((bad, cfg, INITIAL, ReestimationConfig(method="max_likelihood", budget_passes=10)), 30.0)
        out = wait(w)
        assert out.status == "error" and "no GNSS" in out.value
        # a job that does not stop by the worker's limit (0.2 s + 0.5 s grace) is abandoned
        slow = ReestimationConfig(method="cmaes", budget_passes=100000, timeout_s=100.0)
        w.submit((pm_window, cfg, INITIAL, slow), 0.2)
        out = wait(w)
        # abandoned, not finished: its 100000 passes take minutes; how soon depends on the machine's load
        assert out.status == "timeout" and out.wall_s >= 0.2 + 0.5 and w.n_restarts == 1 and not w.busy
    finally:
        w.close()


def test_a_job_past_its_deadline_stops_and_is_not_accepted(doublet, pm_window):
    """The job's own deadline (checked before every pass): it stops and is not
    accepted; within its deadline the same job is accepted with a CRB sigma."""
    _, cfg, _ = doublet
    rc = ReestimationConfig(method="cmaes", budget_passes=12, timeout_s=1e-3)
    res = reestimate(pm_window, cfg, INITIAL, rc)
    assert not res.accepted and res.reason.startswith("timed out") and res.n_passes <= 1
    np.testing.assert_allclose(res.initial_freqs_radps, INITIAL)
    res = reestimate(pm_window, cfg, INITIAL, dataclasses.replace(rc, timeout_s=60.0))
    assert res.accepted and res.reward > res.reward_initial and res.n_passes == 12 + 7
    assert res.sigma_radps is not None and np.all(res.sigma_radps > 0)
