"""Geomagnetic fixes reach the fusion filter over DDS through a declared
source (seed003_geomag: ``filter.sources.geomag``, type ``position_fix``),
the filter takes every one, on time (none after its epoch was released),
the along-gradient error goes and the across-gradient error stays (the
physics of a near-planar field), and the node's core run offline over the
recorded bag gives the same fixes: the live node matches against the newest
solution carried forward, the offline run against the solution at the
sample's own epoch, and the information of a fix (its coordinate along the
field gradient, its variance) is the same to a small fraction of its sigma."""
import numpy as np
import pytest

from hyper_nav_aiding.geomag.core.geomag_aiding import GeomagAiding
from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig
from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap
from hyper_nav_aiding.geomag.core.matching import LocalFrame
from hyper_nav_aiding.geomag.conversions import mag_sample, nav_point
from hyper_nav_filter.conversions import stamp_to_s
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.graph import Graph
from hyper_nav_workbench.core.scoring import errors, states_from_msgs
from hyper_nav_workbench.report import delivery_check, load_run

pytestmark = pytest.mark.graph

DURATION_S, START_S = 24.0, 4.0
MAP = {"lat_min_deg": 40.0, "lat_max_deg": 41.0, "lon_min_deg": 111.0, "lon_max_deg": 112.0,
       "grid_step_deg": 0.05, "refine_factor": 40}


def test_geomag_fixes_reach_the_fusion_filter_over_dds(tmp_path):
    overrides = {
        "duration_s": DURATION_S, "flight.duration_s": DURATION_S, "graph.real_time_factor": 4.0,
        "geomag.start_s": START_S, "geomag.map": {**GeomagConfig().map.__dict__, "alt_m": 26000.0, **MAP},
        "geomag.map_cache_dir": str(tmp_path / "maps"), "geomag.field_sigma_nT": 0.1,
        "magnetometer.map_error_rms_nT": 0.1,
        "filter.initial_error.pos_enu_m": [300.0, -200.0, 5.0], "filter.config.init_pos_sigma_m": [300.0, 300.0, 5.0],
    }
    bag = tmp_path / "bag"
    with Graph("seed003_geomag", record=bag, overrides=overrides, log_dir=tmp_path / "logs") as g:
        assert "geomag" in g.nodes
        scenario = g.scenario
        g.wait_until_done()
    run = load_run(bag)
    delivered = delivery_check(run)
    for topic in ("geomag/fix", "geomag/quality"):          # this node's outputs, all recorded
        assert delivered[topic]["published"] == delivered[topic]["recorded"] > 0, (topic, delivered[topic])
    fusion = run["diagnostics"]["hyper_nav_filter: fusion"]
    geomag = run["diagnostics"]["hyper_nav_aiding: geomag"]
    n_fix = int(geomag["fixes"])
    assert n_fix >= DURATION_S - START_S - 3 and geomag["map"] == "ok", geomag
    # run_graph gave the node the flight's date; the map is of that date: nothing implied (issue 27)
    assert geomag["flight_epoch_decimal_year"] == str(scenario["magnetometer.epoch_decimal_year"]) == "2025.5"
    assert float(geomag["map_epoch_bias_mean_nT"]) == 0.0 and float(geomag["map_epoch_bias_track_nT"]) == 0.0
    # every fix that reached the filter was taken (the last may come after it stopped)
    assert int(fusion["processed geomag/fix"]) == int(fusion["position_fix_accepted"]) >= n_fix - 1
    # on time: none stale; after its epoch was released only under heavy load (4 of 26 at load 15 on 2 cores)
    assert int(fusion.get("rejected geomag/fix", 0)) == 0
    assert int(fusion.get("position_fix_after_release", 0)) < n_fix / 3
    # physics: the along-gradient error (initially ~ -270 m) goes, the across one (~ 250 m) stays
    err = errors(states_from_msgs(run["nav"]), states_from_msgs(run["truth"]))
    late = err["t"] > DURATION_S - 5.0
    u = np.array([-1.25, 4.3]) / np.hypot(1.25, 4.3)          # the field gradient here, ~16 deg west of north
    along = err["pos_enu_m"][late, :2] @ u
    across = err["pos_enu_m"][late, :2] @ np.array([u[1], -u[0]])
    print(f"\n{n_fix} geomagnetic fixes; last 5 s: along-gradient error max {np.abs(along).max():.1f} m, "
          f"across {np.abs(across).min():.0f}-{np.abs(across).max():.0f} m")
    assert np.abs(along).max() < 40.0
    assert np.abs(across).min() > 150.0
    # the same core offline over the recorded inputs gives the same fixes
    recs = list(read_bag(bag))
    mags = [deserialize(r.raw, r.msgtype) for r in recs if r.topic == "/imu/mag"]
    navs = {round(stamp_to_s(m.header.stamp), 6): m for m in
            (deserialize(r.raw, r.msgtype) for r in recs if r.topic == "/nav/delayed/state")}
    live = [deserialize(r.raw, r.msgtype) for r in recs if r.topic == "/geomag/fix"]
    cfg = GeomagConfig.from_dict({k: v for k, v in scenario.data["geomag"].items() if k != "reproduction"})
    from hyper_nav_aiding.geomag.core.geomag_map import cached_map_path, load_map
    aiding = GeomagAiding(cfg, load_map(cached_map_path(cfg.map, cfg.map_cache_dir), cfg.map))
    offline = []
    for m in mags:
        s = mag_sample(m)
        nav = navs.get(round(s.t_s, 6))
        if nav is not None:
            res = aiding.process(s, nav_point(nav))
            if res is not None and res.valid:
                offline.append(res)
    # around shutdown the last sample may lack its recorded solution (offline) or its fix (live)
    assert len(live) == n_fix
    by_t = {round(r.t_s, 6): r for r in offline}
    common = [b for b in live if round(stamp_to_s(b.header.stamp), 6) in by_t]
    assert len(common) >= n_fix - 1
    for b in common:
        a = by_t[round(stamp_to_s(b.header.stamp), 6)]
        w, V = np.linalg.eigh(a.cov_enu_m2)
        u3 = V[:, 0]                                               # the informed direction
        en = LocalFrame(a.lat_rad, a.lon_rad, a.alt_m).to_en(np.deg2rad(b.latitude), np.deg2rad(b.longitude))
        d3 = np.array([en[0], en[1], b.altitude - a.alt_m])
        # the measurement differencing (map error correlated along the track) multiplies the
        # reference velocities' difference (cm/s) by a / (1 - a) ~ 12: agreement to 5 % of sigma
        assert abs(d3 @ u3) < 0.05 * np.sqrt(w[0]), (d3, d3 @ u3, np.sqrt(w[0]))
        wb = np.linalg.eigvalsh(np.asarray(b.position_covariance).reshape(3, 3))
        assert wb[0] == pytest.approx(w[0], rel=1e-3)
    assert isinstance(aiding.map, GeomagMap)
