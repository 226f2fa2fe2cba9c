"""Virtual GNSS in the live graph: scenario seed004_virtual (seed 004 flight,
every satellite loses lock, here at 10 s) with the virtual_gnss node
(hyper_nav_aiding) started from the scenario's ``virtual_gnss`` block. Over
DDS it takes gnss/raw, gnss/ephemeris, imu/data_raw and the fusion node's
nav/state, and publishes gnss/virtual only during the loss, every channel
flagged virtual, stamped with its receiver epoch; the same core over the
recorded bag (offline, in log order) gives the same virtual epochs, and the
fusion node takes every one of them through its declared source
``gnss_virtual`` (type gnss_raw, virtual channels)."""
import numpy as np
import pytest

from hyper_nav_aiding.virtual_gnss.offline import run_virtual_offline
from hyper_nav_aiding.virtual_gnss.parameters import VirtualGnssNodeParams, from_scenario
from hyper_nav_filter.conversions import stamp_to_s
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.report import delivery_check, load_run

pytestmark = pytest.mark.graph

DURATION_S = 16.0
T_LOSS_S = 10.0         # the scenario's loss of lock (30 s) moved to 10 s: 20 s less of graph run


def test_virtual_gnss_node_over_dds_matches_its_offline_core(tmp_path):
    bag = tmp_path / "seed004_virtual"
    with Graph("seed004_virtual", record=bag, log_dir=tmp_path / "logs",
               overrides={"duration_s": DURATION_S, "graph.real_time_factor": 2.0,
                          "gnss.raw.lock.outages": [[T_LOSS_S, 500.0]]}) as g:
        g.wait_until_done()
        sc = g.scenario
        log = g.log("virtual_gnss")
    assert "virtual_gnss" in g.nodes
    assert "subscribed to /gnss/ephemeris, /gnss/raw, /imu/data_raw, /nav/delayed/state" in log, log[-2000:]
    run = load_run(bag)
    delivery = delivery_check(run)
    for topic, d in delivery.items():
        assert d["published"] == d["recorded"], (topic, d)
    # the fusion node takes them through its own declared source (filter.sources.gnss_virtual)
    fusion = run["diagnostics"]["hyper_nav_filter: fusion"]
    print("\nfusion diagnostics: " + ", ".join(f"{k}={v}" for k, v in fusion.items() if "virtual" in k or "raw" in k))
    diag = run["diagnostics"]["hyper_nav_aiding: virtual_gnss"]
    assert not any(k.startswith("rejected_") and int(v) for k, v in diag.items()), diag
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(bag)]
    live = [m for t, m in records if t == "/gnss/virtual"]
    raw = [m for t, m in records if t == "/gnss/raw"]
    stamps = [stamp_to_s(m.header.stamp) for m in live]
    loss = [stamp_to_s(m.header.stamp) for m in raw if not any(m.locked)]
    print(f"\n{len(live)} virtual epochs at {stamps[0] if stamps else None}..{stamps[-1] if stamps else None} s; "
          f"receiver epochs without lock {len(loss)}; virtual node counters {diag}")
    # exactly the receiver epochs without lock, nothing before the loss, each stamped with its epoch; an
    # epoch is processed once the IMU is input_hold_s past it (inputs up to that late are in): the
    # flight's last one (at its last IMU sample) stays held
    hold = VirtualGnssNodeParams.from_values(from_scenario(sc)).config.input_hold_s
    assert hold > 0 and loss[-1] == pytest.approx(DURATION_S)
    held = [t for t in loss if t > DURATION_S - hold + 1e-9]
    assert stamps == [t for t in loss if t not in held] and min(loss) == pytest.approx(T_LOSS_S)
    assert int(diag["published gnss/virtual"]) == len(live) == int(DURATION_S - T_LOSS_S) + 1 - len(held)
    for m in live:
        assert len(m.prn) >= 6 and all(m.is_virtual) and all(m.locked)
        assert len(m.elevation_rad) == len(m.prn) and min(m.elevation_rad) >= np.deg2rad(7.5) - 1e-9
    assert int(fusion["processed gnss/virtual"]) == len(live)
    assert int(fusion["gnss_virtual channels_used"]) == sum(len(m.prn) for m in live)
    # offline: the node's input handler over the bag in log order
    off, inp = run_virtual_offline(records, VirtualGnssNodeParams.from_values(from_scenario(sc)))
    assert len(off) == len(live)
    for m, (e, el, _) in zip(live, off):
        assert stamp_to_s(m.header.stamp) == pytest.approx(e.t_s, abs=1e-9)
        assert list(m.prn) == [int(p) for p in e.prn]
        # same to the micrometre (live and offline differ at 1e-9 relative: float noise)
        np.testing.assert_allclose(m.pseudorange_m, e.pseudorange_m, rtol=0, atol=1e-5)
        np.testing.assert_allclose(m.pseudorange_rate_mps, e.rate_mps, rtol=0, atol=1e-5)
        np.testing.assert_allclose(m.elevation_rad, el, rtol=0, atol=1e-12)
