"""The report's figures do not depend on the order the recorder got the
messages in (issue 22): errors are paired by stamp and summed in time order;
a node's last diagnostics are its highest heartbeat, not the last logged."""
import numpy as np

from hyper_nav_workbench.core.scoring import errors, summarize
from hyper_nav_workbench.report import _newer


def states(t, lat_off):
    n = len(t)
    return {"t": np.asarray(t, float), "lat": 0.5 + lat_off, "lon": np.full(n, 2.0), "alt": np.full(n, 3e4),
            "vel": np.tile([0.0, 1700.0, 0.0], (n, 1)), "C": np.tile(np.eye(3), (n, 1, 1))}


def test_summary_is_bitwise_the_same_for_shuffled_solutions():
    rng = np.random.default_rng(22)
    t = np.arange(0, 60, 0.02)
    nav = states(t, rng.normal(0, 1e-7, len(t)))
    truth = states(t, np.zeros(len(t)))
    ref = summarize(errors(nav, truth), 10.0)
    perm = rng.permutation(len(t))
    shuffled = {k: v[perm] for k, v in nav.items()}
    assert summarize(errors(shuffled, states(t[::-1], np.zeros(len(t)))), 10.0) == ref
    assert ref["epochs"] == int(np.sum(t >= 10.0))


def test_last_diagnostics_by_heartbeat():
    assert _newer({"heartbeat": "7"}, {"heartbeat": "6"})
    assert not _newer({"heartbeat": "5"}, {"heartbeat": "6"})     # an older status recorded late
    assert _newer({"x": "1"}, {"x": "0"}) and _newer({"heartbeat": "1"}, None)
