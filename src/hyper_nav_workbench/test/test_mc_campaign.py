"""Monte Carlo campaigns on dask.distributed: the same seeds give the same
numbers on one worker and on two (LocalCluster processes), the draws come
from the scenario's own distributions, and the chi-square bands are right."""
import json

import numpy as np
import pytest
from scipy.stats import chi2

from hyper_nav_workbench.core import montecarlo
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario
from hyper_nav_workbench.mc_campaign import _jsonable, campaign, plot


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    return apply_overrides(load_scenario("default"), {"duration_s": 4.0, "report.skip_s": 1.0},
                           tmp_path_factory.mktemp("mc"))


def test_same_numbers_on_one_and_two_workers(short, tmp_path):
    """One LocalCluster of two worker processes, reached as an existing
    cluster (--scheduler): the campaign on one of its workers, then on both."""
    from hyper_nav_workbench.campaign import local_cluster
    with local_cluster(2) as cluster:
        one = campaign(short.data, runs=4, scheduler=cluster.scheduler_address, max_workers=1)
        two = campaign(short.data, runs=4, scheduler=cluster.scheduler_address)
    assert one["workers"] == 1 and two["workers"] == 2
    a, b = (json.dumps(_jsonable({"per_run": r["per_run"], "stats": r["stats"]}), sort_keys=True) for r in (one, two))
    assert a == b
    s = one["stats"]
    assert s["n_runs"] == 4 and len(s["t_s"]) == 4 and set(s["anis"]) == {"gnss_pos", "gnss_vel"}
    assert len({r["seed"] for r in one["per_run"]}) == 4
    for r in one["per_run"]:      # 4 s of the default flight: metre-level position, sub-0.5 m/s velocity
        assert 0.0 < r["pos_rms_3d"] < 15.0 and 0.0 < r["vel_rms_3d"] < 0.5
    pngs = plot(one, tmp_path)
    assert all(p.stat().st_size > 10_000 for p in pngs)


def test_draws_follow_the_filter_prior_and_depend_on_the_run_only():
    sc = load_scenario("default")
    cfg = sc.filter_config()
    draws = [montecarlo.draw_overrides(sc.data, cfg, k) for k in range(400)]
    assert draws[7] == montecarlo.draw_overrides(sc.data, cfg, 7)
    g = np.array([d["imu.gyro_bias_deg_per_hr"] for d in draws])
    p = np.array([d["filter.initial_error.pos_enu_m"] for d in draws])
    # sample sigma within 10 % of the prior (400 draws: 1-sigma of the estimate ~3.5 %)
    assert g.std(axis=0) == pytest.approx(np.asarray(cfg.gyro_bias_sigma_deg_per_hr), rel=0.1)
    assert p.std(axis=0) == pytest.approx(np.asarray(cfg.init_pos_sigma_m), rel=0.1)
    only_noise = montecarlo.draw_overrides(sc.data, cfg, 3, draws=("noise",))
    assert set(only_noise) == {"seed"} and only_noise["seed"] == draws[3]["seed"]


def test_anees_band_covers_95_percent_of_simulated_averages():
    rng = np.random.default_rng(5)
    n, dof = 20, 3
    lo, hi = montecarlo.band(n, dof)
    means = chi2.rvs(dof, size=(4000, n), random_state=rng).mean(axis=1)
    assert np.mean((means > lo) & (means < hi)) == pytest.approx(0.95, abs=0.015)


@pytest.mark.parametrize("name, duration_s, kind", [("seed004_tight", 6.0, "pseudorange"),
                                                    ("seed003", 6.0, "baro")])
def test_tightly_coupled_and_barometric_scenarios_are_drawn(tmp_path, name, duration_s, kind):
    """mc_campaign runs take the scenario's declared sources: pseudoranges and barometric heights reach the filter."""
    sc = apply_overrides(load_scenario(name), {"duration_s": duration_s, "report.skip_s": 1.0}, tmp_path)
    r = montecarlo.run_one(sc.data, 0)
    assert any(k.startswith(kind) for k in r["gated"]), r["gated"]
    m = montecarlo.run_metrics(r, 1.0)
    assert np.isfinite(m["pos_rms_3d"]) and m["pos_rms_3d"] < 50.0
    again = montecarlo.run_one(sc.data, 0)                    # a run depends on (scenario, k) only
    assert np.array_equal(again["err"]["pos"], r["err"]["pos"])


def test_a_source_no_simulated_sensor_or_configured_aiding_node_feeds_is_refused_by_name(tmp_path):
    """A map-matching source without the geomag block (nothing publishes its
    topic), and a source on an aiding node's output whose package declares no
    Monte Carlo feed (the lever-arm learner's model updates): refused, naming
    the source (and the node)."""
    data = apply_overrides(load_scenario("default"), {"duration_s": 2.0}, tmp_path).data
    data["filter"]["sources"] = {"imu": {"type": "imu", "topic": "imu/data_raw"},
                                 "geomag": {"type": "horizontal_fix", "topic": "geomag/fix"}}
    with pytest.raises(ValueError, match="filter.sources.geomag: type 'horizontal_fix' on 'geomag/fix' is not drawn"):
        montecarlo.run_one(data, 0)
    data = apply_overrides(load_scenario("seed000_elastic"), {"duration_s": 2.0}, tmp_path).data
    with pytest.raises(ValueError, match="filter.sources.lever_arm: its topic 'nav/model_update' is aiding node "
                                         "'lever_arm''s output, which is not drawn"):
        montecarlo.run_one(data, 0)


GEOMAG_DURATION_S, GEOMAG_START_S = 24.0, 4.0


def test_map_matching_is_drawn_with_the_geomag_node_in_the_loop(tmp_path):
    """seed003_geomag (position fixes from the geomag node): each run's own
    magnetometer draw goes through the node's logic against the run's own
    released solutions (``hyper_nav_aiding.geomag.mc_feed``) and its fixes reach
    the filter through the declared source. The set-up and physics of the
    graph test (test/test_geomag_graph.py): 300/-200 m initial horizontal
    error, a small map; a fix per second from 4 s on, all taken; the
    along-gradient error goes (below 40 m over the last 5 s), the
    across-gradient error stays (above 150 m). The run depends on (scenario,
    k) only."""
    from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig
    over = {"duration_s": GEOMAG_DURATION_S, "flight.duration_s": GEOMAG_DURATION_S, "report.skip_s": 1.0,
            "geomag.start_s": GEOMAG_START_S,
            "geomag.map": {**GeomagConfig().map.__dict__, "alt_m": 26000.0, "lat_min_deg": 40.0, "lat_max_deg": 41.0,
                           "lon_min_deg": 111.0, "lon_max_deg": 112.0, "grid_step_deg": 0.05, "refine_factor": 40},
            "geomag.map_cache_dir": str(tmp_path / "maps"), "geomag.field_sigma_nT": 0.1,
            "magnetometer.map_error_rms_nT": 0.1,
            "filter.initial_error.pos_enu_m": [300.0, -200.0, 5.0],
            "filter.config.init_pos_sigma_m": [300.0, 300.0, 5.0]}
    data = apply_overrides(load_scenario("seed003_geomag"), over, tmp_path).data
    r = montecarlo.run_one(data, 0, draws=("noise",))         # the initial error as set above
    (counts,) = r["aiding"]
    n_fix = counts["published geomag/fix"]
    assert n_fix >= GEOMAG_DURATION_S - GEOMAG_START_S - 3, counts
    assert r["accepted"]["position_fix"] == n_fix and r["gated"]["position_fix"] == 0, (r["accepted"], r["gated"])
    late = r["t_s"] > GEOMAG_DURATION_S - 5.0
    u = np.array([-1.25, 4.3]) / np.hypot(1.25, 4.3)          # the field gradient there (the graph test's)
    along = r["err"]["pos"][late, :2] @ u
    across = r["err"]["pos"][late, :2] @ np.array([u[1], -u[0]])
    print(f"\n{n_fix} fixes; last 5 s: along-gradient |error| max {np.abs(along).max():.1f} m, "
          f"across {np.abs(across).min():.0f}-{np.abs(across).max():.0f} m")
    assert np.abs(along).max() < 40.0
    assert np.abs(across).min() > 150.0
    again = montecarlo.run_one(data, 0, draws=("noise",))
    assert np.array_equal(again["err"]["pos"], r["err"]["pos"]) and again["aiding"] == r["aiding"]


class _SlowToReap:
    """A local cluster whose close times out the way dask's nanny does when a
    killed worker process is reaped late (a loaded CI machine)."""
    closed = False

    def close(self):
        self.closed = True
        raise TimeoutError


class _Client:
    closed = False

    def close(self):
        self.closed = True


def test_a_cluster_shutdown_timeout_after_the_results_is_reported_not_raised():
    from hyper_nav_workbench.campaign import _shut_down
    lines: list[str] = []
    client, cluster = _Client(), _SlowToReap()
    _shut_down(client, cluster, lines.append)
    assert client.closed and cluster.closed
    assert len(lines) == 1 and "shutdown timed out" in lines[0] and "all results are in" in lines[0]


def test_a_cluster_shutdown_error_that_is_not_a_timeout_still_raises():
    from hyper_nav_workbench.campaign import _shut_down

    class Broken:
        def close(self):
            raise RuntimeError("scheduler gone")
    with pytest.raises(RuntimeError, match="scheduler gone"):
        _shut_down(_Client(), Broken(), print)
