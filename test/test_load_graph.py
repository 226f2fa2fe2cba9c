"""Nothing lost under load (issue 33): the graph flies beside a CPU-bound
process at normal priority while one node is frozen (SIGSTOP) and resumed,
and every message published is recorded, received and processed.

The short form of ``load_flight`` (``hyper_nav_workbench.load_harness``). The
frozen node is the IMU node, which lost 354 of the 8,000 ``imu/load``
messages at the recorder before the fix (a frozen producer released its
backlog in one burst, deeper than its consumers' queues, after the clock had
run on without it). The recorder's own accounting (its ``recorded <topic>``
status and the bag) is checked against the publishers' counts."""
import threading
import time

import pytest

from hyper_nav_workbench.core import run_check
from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.load_harness import BusyProcesses, freeze
from hyper_nav_workbench.report import delivery_check, load_run

pytestmark = pytest.mark.graph

FREEZE_S = 3.0


def test_a_frozen_imu_node_beside_a_busy_process_loses_nothing(tmp_path):
    bag, logs = tmp_path / "bag", tmp_path / "logs"
    frozen = {}

    def freeze_imu_once_flying(g):
        truth_log = logs / "truth.log"
        while g.procs["truth"].poll() is None:
            if truth_log.is_file() and "flying" in truth_log.read_text(errors="replace"):
                time.sleep(1.0)
                frozen["s"] = freeze(g.procs["imu"].pid, FREEZE_S)
                return
            time.sleep(0.1)

    with BusyProcesses(1) as busy, Graph("seed000_elastic", record=bag, log_dir=logs,
                                         nodes=("truth", "imu", "gnss", "mag", "fusion"),
                                         overrides={"duration_s": 20.0, "graph.real_time_factor": 3.0}) as g:
        assert len(busy.pids) == 1
        worker = threading.Thread(target=freeze_imu_once_flying, args=(g,), daemon=True)
        worker.start()
        g.wait_until_done()
        worker.join()
    assert frozen.get("s", 0.0) >= FREEZE_S

    run = load_run(bag)
    delivery = delivery_check(run)
    assert delivery["imu/load"]["published"] == 8000 and delivery["imu/data_raw"]["published"] == 1000
    for topic, d in delivery.items():                       # every publisher's count against the bag
        assert d["published"] == d["recorded"] > 0, (topic, d)
    rows = run_check.delivery_rows(run["by_node"], run["counts"], run_check.Outcome())
    assert run_check.delivery_losses(rows) == [], rows      # ... and against what fusion received, processed
    fusion = run["diagnostics"]["hyper_nav_filter: fusion"]
    for topic in ("imu/data_raw", "imu/load", "gnss/fix", "gnss/vel"):
        assert int(fusion[f"received {topic}"]) == int(fusion[f"processed {topic}"]) \
            == delivery[topic]["published"], topic
    # the recorder's own accounting (its last status) is the bag's
    recorder = run["diagnostics"]["hyper_nav_sim: recorder"]
    counts = {t.lstrip("/"): n for t, n in run["counts"].items()}
    for topic in delivery:
        assert int(recorder[f"recorded {topic}"]) == counts[topic], topic
    assert not any(k.startswith("lost ") for k in recorder), recorder       # its own sequence accounting
    # the clock waited for the frozen node (the gate held it) instead of running on without it
    truth = run["diagnostics"]["hyper_nav_sim: truth"]
    assert float(truth["clock_held_s"]) >= 1.0, truth
