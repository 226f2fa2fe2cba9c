"""The time source's /clock cap (``graph.clock_max_wall_hz``): at 20x real time
the default scenario's 50 Hz /clock would be 1000 messages per wall second into
every node; capped at 100, sim time advances in 0.2 s steps while the truth keeps
its 50 Hz epochs and the fusion node still receives every IMU sample (issue 15).
Real graph over DDS; only /clock, truth/state and /diagnostics are recorded."""
import numpy as np
import pytest

from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.report import load_run

pytestmark = pytest.mark.graph

DURATION_S, RTF = 12.0, 20.0


def _stamps(records, msgtype, field):
    out = []
    for r in records:
        m = deserialize(r.raw, msgtype)
        st = getattr(m, field) if field else m.header.stamp
        out.append(st.sec + st.nanosec * 1e-9)
    return np.array(out)


def test_clock_is_capped_in_wall_time_and_nothing_is_lost(tmp_path):
    over = {"duration_s": DURATION_S, "graph.real_time_factor": RTF}
    with Graph("default", record=tmp_path / "bag", overrides=over, log_dir=tmp_path / "logs",
               node_params={"recorder": {"topics": ["/clock", "/truth/state", "/diagnostics"]}}) as g:
        g.wait_until_done()
    by_topic = {}
    for rec in read_bag(tmp_path / "bag"):
        by_topic.setdefault(rec.topic, []).append(rec)
    step = RTF / 100.0                                          # graph.clock_max_wall_hz = 100 (default)
    clock = _stamps(by_topic["/clock"], "rosgraph_msgs/msg/Clock", "clock")
    assert np.allclose(np.diff(clock), step, atol=1e-6), np.unique(np.round(np.diff(clock), 6))
    assert clock[-1] >= DURATION_S and len(clock) == int(np.ceil((DURATION_S + 1.0) / step - 1e-9)) + 1
    truth = _stamps(by_topic["/truth/state"], "hyper_nav_msgs/msg/NavState", None)
    assert len(truth) == int(DURATION_S * 50) + 1 and np.allclose(np.diff(truth), 0.02, atol=1e-6)
    fusion = load_run(tmp_path / "bag")["diagnostics"]["hyper_nav_filter: fusion"]
    imu_published = int(DURATION_S * 50)
    assert int(fusion["received imu/data_raw"]) == int(fusion["processed imu/data_raw"]) == imu_published
