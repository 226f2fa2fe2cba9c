"""Re-estimation job and worker process (core.lever_arm.reestimate,
core.lever_arm.worker): a job that raises or outlives its limit is reported,
never raised, and the worker is ready again afterwards."""
import dataclasses
import time

import numpy as np
from hyper_nav_filter.core.elastic_lever_arm import TABLE2_FREQ_RADPS

INITIAL = np.asarray(TABLE2_FREQ_RADPS)

from hyper_nav_aiding.core.lever_arm.reestimate import ReestimationConfig, reestimate
from hyper_nav_aiding.core.lever_arm.worker import ReestimationWorker


def wait(worker, timeout_s=60.0):
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        out = worker.poll()
        if out is not None:
            return out
        time.sleep(0.05)
    raise TimeoutError


def test_failed_and_timed_out_jobs_are_reported(doublet, pm_window):
    _, cfg, _ = doublet
    w = ReestimationWorker(warm_up=False, grace_s=0.5)
    try:
        bad = dataclasses.replace(pm_window, gnss=())
        w.submit((bad, cfg, INITIAL, ReestimationConfig(method="max_likelihood", budget_passes=10)), 30.0)
        out = wait(w)
        assert out.status == "error" and "no GNSS" in out.value
        # the job's own deadline: it stops between passes and is not accepted
        slow = ReestimationConfig(method="cmaes", budget_passes=100000, timeout_s=0.3)
        w.submit((pm_window, cfg, INITIAL, slow), 30.0)
        out = wait(w)
        assert out.status == "ok" and not out.value.accepted and out.value.reason.startswith("timed out")
        # a job that does not stop by the worker's limit (0.2 s + 0.5 s grace) is abandoned
        w.submit((pm_window, cfg, INITIAL, dataclasses.replace(slow, timeout_s=100.0)), 0.2)
        out = wait(w)
        assert out.status == "timeout" and out.wall_s < 10.0 and w.n_restarts == 1 and not w.busy
        w.submit((pm_window, cfg, INITIAL, ReestimationConfig(method="max_likelihood", budget_passes=10)), 60.0)
        out = wait(w)
        assert out.status == "ok" and out.value.n_passes <= 10 + 7
    finally:
        w.close()


def test_a_job_past_its_deadline_is_not_accepted(doublet, pm_window):
    _, cfg, _ = doublet
    res = reestimate(pm_window, cfg, INITIAL, ReestimationConfig(method="cmaes", budget_passes=30, timeout_s=1e-3))
    assert not res.accepted and res.reason.startswith("timed out")
    np.testing.assert_allclose(res.initial_freqs_radps, INITIAL)
