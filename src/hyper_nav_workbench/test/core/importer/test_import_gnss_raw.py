"""import_data presets ``ubx`` and ``rinex`` (core/importer/gnss_raw.py): real
receiver data -> gnss/raw + gnss/ephemeris (+ imu/data_raw) in a bag that
reads back to the same epochs, and the filter on it offline (replay through
the declared sources, as replay_filter and the fusion node take it).
Data from ../shared/real-data, written to tmp_path at test time."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import yaml

from hyper_nav_filter import conversions
from hyper_nav_filter.core.params import ConfigError
from hyper_nav_workbench import import_data
from hyper_nav_workbench.core.bag import deserialize, read_bag

_spec = importlib.util.spec_from_file_location(
    "hyper_nav_gnss_real_data", Path(__file__).resolve().parents[4] / "hyper_nav_gnss" / "test" / "_real_data.py")
rd = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rd)

WALK_IMU_MAP = {"time": {"column": 0, "unit": "s"}, "kind": "rates", "gyro": {"columns": [4, 5, 6], "unit": "rad/s"},
                "accel": {"columns": [1, 2, 3], "unit": "g"}, "body": "FLU"}
T_IMU0 = 1756402240.961          # first IMU record (GPST as Unix seconds, the walk's IMU time)


def _import(tmp_path, doc, name="bag"):
    f = tmp_path / f"{name}.yaml"
    f.write_text(yaml.safe_dump(doc))
    imported = import_data.load_import(f)
    counts = import_data.write(imported, tmp_path / name)
    return imported, counts


def _records(bag):
    return [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(bag)]


def test_ubx_log_to_bag_and_back(tmp_path):
    from hyper_nav_gnss.formats.ubx import read_ubx
    ubx = rd.real_file(rd.WALK_UBX)
    imported, counts = _import(tmp_path, {"preset": "ubx", "gnss": {"file": str(ubx)}})
    assert counts == {"/gnss/ephemeris": 19, "/gnss/raw": 536}
    assert imported["setup"] is None and not (tmp_path / "bag" / "filter.yaml").exists()
    g = imported["gnss_raw"]
    assert g.counts["channels_dropped_system_S"] == 1579              # SBAS: no GnssMeasurements system code
    reader = read_bag(tmp_path / "bag")
    assert reader.qos["/gnss/ephemeris"][0]["durability"] == "transient_local"
    recs = _records(tmp_path / "bag")
    assert recs[0][0] == "/gnss/ephemeris"                            # records before the first epoch
    log = read_ubx(ubx)
    raws = [conversions.gnss_raw(m) for t, m in recs if t == "/gnss/raw"]
    for ep, back in zip(log.epochs[::50], raws[::50]):
        keep = [k for k, s in enumerate(ep.system) if s != "S"]
        assert back.t_s == pytest.approx(ep.t_rx_gpst_s + 315964800.0, abs=1e-6)   # stamp: GPST on the Unix epoch
        assert back.t_rx_gpst_s == pytest.approx(ep.t_rx_gpst_s, abs=1e-9)
        assert list(back.signal) == [ep.signal[k] for k in keep]
        np.testing.assert_array_equal(back.pseudorange_m, ep.pseudorange_m[keep])
        np.testing.assert_array_equal(back.cn0_dbhz, ep.cn0_dbhz[keep])
        np.testing.assert_array_equal(back.tracking_flags, ep.tracking_flags[keep])
        np.testing.assert_array_equal(back.lock_time_s, ep.lock_time_s[keep])
    ephs = [(conversions.gnss_ephemeris(m), conversions.gnss_ephemeris_klobuchar(m)) for t, m in recs
            if t == "/gnss/ephemeris"]
    assert sorted({e.system for e, _ in ephs}) == ["C", "E", "G"]
    assert all(kb is not None and kb[0] == "C" for e, kb in ephs if e.system == "C")   # BDS D1 Klobuchar rides along
    assert {e.sat_id for e, _ in ephs} == {e.sat_id for e in log.records()}


def test_rinex_files_to_bag_window_and_errors(tmp_path):
    doc = {"preset": "rinex", "gnss": {"file": str(rd.real_file(rd.TLSE_OBS)), "nav": str(rd.real_file(rd.TLSE_NAV)),
                                       "signals": {"G": ["1C", "2W"], "E": ["1X", "7X"]}, "time_axis": "gpst"},
           "end_s": 2295 * 604800.0 + 129600.0 + 29.0}
    imported, counts = _import(tmp_path, doc)
    assert counts["/gnss/raw"] == 30
    assert counts["/gnss/ephemeris"] == 452 + 5390 + 1080                # G, E, C records (QZSS: no message code)
    raws = [conversions.gnss_raw(m) for t, m in _records(tmp_path / "bag") if t == "/gnss/raw"]
    assert raws[0].t_s == 2295 * 604800.0 + 129600.0 and set(raws[0].signal) == {"1C", "2W", "1X", "7X"}
    bad = dict(doc, gnss={**doc["gnss"], "file": "nowhere.crx.gz"})
    with pytest.raises(ConfigError, match=r"gnss.file: .*nowhere.crx.gz not found"):
        _import(tmp_path, bad, "bad1")
    with pytest.raises(ConfigError, match=r"gnss.navigation: unknown field"):
        _import(tmp_path, dict(doc, gnss={**doc["gnss"], "navigation": "x"}), "bad2")
    with pytest.raises(ConfigError, match=r"filter: needs an imu block"):
        _import(tmp_path, dict(doc, filter={"config": {}}), "bad3")


@pytest.fixture(scope="module")
def walk_with_imu(tmp_path_factory):
    # range_errors white: the filter these tests were written for (SPP start, standing still, within 2 m of
    # it). With the default range-bias states (issue 37 item 5: rb32, 2.2 m / 1500 s) the 10 s solution moves
    # up to 3.26 m from the single-epoch SPP start (H 1.79 m, U 2.72 m; at the end 1.2 / 1.4 / 2.7 m E/N/U
    # against its own 1-sigma 1.2 / 1.3 / 2.5 m), white 1.21 m; the whole walk against RTK: docs/walk_imu.md
    tmp = tmp_path_factory.mktemp("walk_imu")
    doc = {"preset": "ubx", "gnss": {"file": str(rd.real_file(rd.WALK_UBX))},
           "imu": {"file": str(rd.real_file(rd.WALK_IMU)), **WALK_IMU_MAP}, "end_s": T_IMU0 + 10.0,
           "filter": {"config": {"state_blocks": ["att", "vel", "pos", "bg", "ba", "clk", "isb"],
                                 "range_errors": "white",
                                 "gyro_arw_deg_per_sqrt_hr": 0.23, "accel_vrw_ug_per_sqrt_hz": 70.0,
                                 "init_gyro_bias_sigma_deg_per_hr": 720.0, "init_accel_bias_sigma_ug": 20000.0,
                                 "init_att_sigma_deg": [10.0, 10.0, 100.0], "init_pos_sigma_m": 5.0,
                                 "clock_bias_sigma_m": 30.0, "clock_drift_sigma_mps": 2.0, "isb_sigma_m": 5.0,
                                 "clock_bias_psd_m2ps": 1.0, "clock_drift_psd_m2ps3": 0.1, "output_rate_hz": 10.0},
                      "sources": {"imu": {"type": "imu", "topic": "imu/data_raw"},
                                  "gnss": {"type": "gnss_raw", "topic": "gnss/raw", "use_rates": True,
                                           "signals": ["G:1C+2L,1C", "E:1C+5Q,1C", "C:6I"],
                                           "error_model": "elevation_cn0", "per_satellite": True}},
                      "initial_state": {"roll_pitch_heading_deg": [0.0, 0.0, 0.0]}}}
    imported, counts = _import(tmp, doc)
    return tmp / "bag", imported, counts


def test_walk_with_imu_filter_setup_from_spp_and_offline_run(walk_with_imu):
    """The first 10 s of the walk (the walker stands still for 11 s): the
    initial position, receiver clock (-462 km: the u-blox clock) and
    inter-system biases come from SPP; offline, every epoch's satellites are
    updates one by one, none gated, and the solution stays within 2 m of the
    SPP position while the IMU says it stands still."""
    from hyper_nav_gnss import earth
    from hyper_nav_filter.filter_setup import FilterSetup
    from hyper_nav_filter.offline import run_offline
    bag, imported, counts = walk_with_imu
    assert counts["/imu/data_raw"] == 1558 and counts["/gnss/raw"] == 45     # 10 s at ~156 Hz; 4 Hz from 1.2 s before
    init = imported["setup"]["filter"]["initial_state"]
    assert init["clock_bias_m"] == pytest.approx(-462600.0, abs=100.0) and init["t_s"] == pytest.approx(T_IMU0)
    setup = FilterSetup.load(bag / "filter.yaml")
    recs = _records(bag)
    sols, eng = run_offline(recs, setup.config, setup.initial, setup.sources)
    g = eng.kf.stats["pseudorange"]
    print(f"\nwalk 10 s offline: {len(sols)} solutions, pseudorange updates accepted {g[0]}, gated {g[1]}; "
          f"{dict(eng.counters)}")
    assert g[0] > 40 * 12 and g[1] <= 0.02 * g[0]
    r0 = earth.geodetic_to_ecef(np.deg2rad(init["lat_deg"]), np.deg2rad(init["lon_deg"]), init["alt_m"])
    d = [np.linalg.norm(earth.geodetic_to_ecef(s.state.lat_rad, s.state.lon_rad, s.state.alt_m) - r0) for s in sols]
    assert max(d) < 2.0


def test_epochs_before_the_filter_start_take_no_range_bias_slots(walk_with_imu):
    """The walk's 10 s with the default range-bias states (rb32): the raw
    epochs before the filter's start are refused as stale and leave the slot
    pool as it was, so the solution is the same bit for bit with and without
    them (a live node receives fewer of them than the bag holds; before the
    fix the whole walk's 52 pre-start epochs moved velocities by 2e-13 m/s
    and the live node differed from the offline core)."""
    from hyper_nav_filter.core.config import FilterConfig
    from hyper_nav_filter.filter_setup import FilterSetup
    from hyper_nav_filter.offline import run_offline
    bag, _, _ = walk_with_imu
    setup = FilterSetup.load(bag / "filter.yaml")
    cfg = FilterConfig.from_dict({**setup.config.as_dict(), "range_errors": "states"})
    assert cfg.layout.has("rb32")
    recs = _records(bag)
    t0 = setup.initial.t_s
    stamp = lambda m: m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec     # noqa: E731
    early = [r for r in recs if r[0] == "/gnss/raw" and stamp(r[1]) <= t0]
    assert len(early) >= 4
    full, eng_full = run_offline(recs, cfg, setup.initial, setup.sources)
    cut, eng_cut = run_offline([r for r in recs if not any(r is e for e in early)], cfg, setup.initial,
                               setup.sources)
    assert eng_full.counters["rejected_pseudorange_stale"] > eng_cut.counters["rejected_pseudorange_stale"]
    assert len(full) == len(cut) > 80
    for a, b in zip(full, cut):
        assert a.t_s == b.t_s and np.array_equal(a.P, b.P) and np.array_equal(a.state.vel_enu_mps, b.state.vel_enu_mps)
        assert (a.state.lat_rad, a.state.lon_rad, a.state.alt_m) == (b.state.lat_rad, b.state.lon_rad, b.state.alt_m)
