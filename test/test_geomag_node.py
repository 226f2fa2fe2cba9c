"""The geomagnetic node over real DDS: fixes from a good map, no fix (counted
on /diagnostics) when the solution leaves the map, for a NaN sample and
with a mismatched map file, and the node keeps running in every case; the
map's epoch against the flight's date (issue 27): half a day apart, the
implied bias on /diagnostics and in every geomag/quality; the issue's 1.5
years, the node refuses to start (exit 2)."""
import os
import pathlib
import signal
import subprocess
import time

import numpy as np
import pytest
import yaml
from ament_index_python.packages import get_package_prefix
from diagnostic_msgs.msg import DiagnosticArray
from hyper_nav_msgs.msg import MatchQuality, NavState
from sensor_msgs.msg import MagneticField, NavSatFix

from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig
from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap, MapSpec
from hyper_nav_aiding.geomag.core.map_epoch import map_epoch_offset
from hyper_nav_aiding.geomag.core.matching import LocalFrame
from hyper_nav_workbench.testing import TopicCollector

SPEC = MapSpec(lat_min_deg=44.0, lat_max_deg=44.5, lon_min_deg=110.0, lon_max_deg=110.5, grid_step_deg=0.05,
               refine_factor=40, alt_m=26000.0)
OFFSET_N_M = 300.0            # the solution is 300 m north of the truth
OFF_MAP_S = (6.0, 7.0)        # the solution jumps off the map for these samples
FLIGHT_EPOCH = 2025.5 + 0.5 / 365.25     # half a day after the map's epoch: +0.045 nT here, within 0.1 nT


def _stamp(msg, t):
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), int(round((t % 1) * 1e9))
    return msg


def _start(tmp, ns, cfg: GeomagConfig, domain_id, flight_epoch):
    params = tmp / f"{ns}.params.yaml"
    p = {**cfg.flat(), "magnetometer.epoch_decimal_year": float(flight_epoch)}
    params.write_text(yaml.safe_dump({"/**": {"ros__parameters": p}}))
    exe = pathlib.Path(get_package_prefix("hyper_nav_aiding")) / "lib" / "hyper_nav_aiding" / "geomag_node"
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id), PYTHONUNBUFFERED="1")
    log = open(tmp / f"{ns}.log", "w")
    return subprocess.Popen([str(exe), "--ros-args", "--params-file", str(params), "-r", f"__ns:=/{ns}"],
                            env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)


def _last_status(msgs) -> dict:
    """The last /diagnostics status of each geomag node: 'good' (map ok) and 'bad'."""
    diag = {}
    for arr in list(msgs["/diagnostics"]):
        for st in arr.status:
            if st.name == "hyper_nav_aiding: geomag":
                v = {kv.key: kv.value for kv in st.values}
                diag["good" if v.get("map") == "ok" else "bad"] = v
    return diag


@pytest.mark.graph
def test_geomag_node_fixes_and_bad_input_over_dds(tmp_path):
    domain_id = int(os.environ["ROS_DOMAIN_ID"])         # this pytest process's own (conftest.py)
    gmap = GeomagMap.build(SPEC)
    map_file = gmap.save(tmp_path / "map.npz")
    # nav_reference_lag_s 0: each sample against the solution of its own stamp (interpolated), which
    # the node takes once the next solution is in (the track below runs 0.5 s past the last sample)
    base = {"algorithm": "EKF", "start_s": 0.0, "field_sigma_nT": 0.5, "map_file": str(map_file),
            "nav_reference_lag_s": 0.0,
            "map": {k: getattr(SPEC, k) for k in SPEC.__dataclass_fields__}, "ekf": {"map_error_corr_length_m": 0.0}}
    good = GeomagConfig.from_dict(base)
    bad = GeomagConfig.from_dict({**base, "map": {**base["map"], "epoch_decimal_year": 2026.0}})
    procs = {"good": _start(tmp_path, "good", good, domain_id, FLIGHT_EPOCH),
             "bad": _start(tmp_path, "bad", bad, domain_id, 2026.0)}
    topics = {"/diagnostics": DiagnosticArray}
    for ns in procs:
        topics[f"/{ns}/geomag/fix"] = NavSatFix
        topics[f"/{ns}/geomag/quality"] = MatchQuality
    try:
        with TopicCollector(topics, domain_id=domain_id) as c:
            pubs = {ns: (c.publisher(NavState, f"/{ns}/nav/delayed/state"), c.publisher(MagneticField, f"/{ns}/imu/mag"))
                    for ns in procs}
            deadline = time.monotonic() + 30.0
            while any(p.get_subscription_count() < 1 for pp in pubs.values() for p in pp):
                assert time.monotonic() < deadline, (tmp_path / "good.log").read_text()
                assert all(p.poll() is None for p in procs.values())
                time.sleep(0.1)
            time.sleep(1.0)                     # discovery is asymmetric: let the readers match these writers too
            # a track north at 2 km/s from 44.1 N 110.2 E; the solution is OFFSET_N_M north of it
            frame = LocalFrame(np.deg2rad(44.1), np.deg2rad(110.2), 26000.0)
            truth, nav_at = {}, {}
            for k in range(0, 126):
                t = 0.1 * k
                true_en = np.array([0.0, 2000.0 * t])
                nav_en = true_en + [0.0, OFFSET_N_M]
                lat, lon = frame.to_geodetic(nav_en)
                if OFF_MAP_S[0] - 0.5 < t < OFF_MAP_S[1] + 0.5:
                    lat = np.deg2rad(44.7)                      # off the map (north of 44.5 N)
                nav = _stamp(NavState(), t)
                nav.lat_rad, nav.lon_rad, nav.alt_m = float(lat), float(lon), 26000.0
                nav_at[round(t, 1)] = (float(lat), float(lon))
                nav.vel_enu_mps = [0.0, 2000.0, 0.0]
                nav.state_blocks, nav.state_dim = ["att:3", "vel:3", "pos:3"], 9
                P = np.eye(9)
                P[6:9, 6:9] = np.diag([500.0**2, 500.0**2, 4.0])
                nav.covariance = P.ravel().tolist()
                for pn, _ in pubs.values():
                    pn.publish(nav)
                if k % 10 == 0 and 0 < k <= 120:
                    tl, tlo = frame.to_geodetic(true_en)
                    f = float(gmap.total_nT(tl, tlo, 26000.0))
                    truth[round(t)] = (float(tl), float(tlo))
                    m = _stamp(MagneticField(), t)
                    u = np.array([0.1, 0.4, -0.9]) / np.linalg.norm([0.1, 0.4, -0.9])
                    m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z = (u * f * 1e-9).tolist()
                    for _, pm in pubs.values():
                        pm.publish(m)
                    if k == 90:
                        nan = _stamp(MagneticField(), t + 0.5)
                        nan.magnetic_field.x = float("nan")
                        for _, pm in pubs.values():
                            pm.publish(nan)
                time.sleep(0.005)
            n_mag = 12                                          # t = 1 ... 12 s (plus the NaN one)
            ok = c.wait_for(lambda m: len(m["/good/geomag/quality"]) >= n_mag and len(m["/bad/geomag/quality"])
                            >= n_mag, 30.0)
            assert ok, (tmp_path / "good.log").read_text()[-3000:] + (tmp_path / "bad.log").read_text()[-3000:]
            # the nodes' statuses (every 1 s) catch up with the last sample
            c.wait_for(lambda m: _last_status(m).get("good", {}).get("fixes") == str(len(m["/good/geomag/fix"]))
                       and _last_status(m).get("bad", {}).get("no_map") == str(n_mag), 15.0)
            assert all(p.poll() is None for p in procs.values()), "a geomag node exited"
            msgs = c.messages
        # good map: a fix for every in-map sample; the along-gradient error is gone
        fixes = msgs["/good/geomag/fix"]
        q_good = msgs["/good/geomag/quality"]
        off = [q for q in q_good if not q.valid]
        assert len(fixes) == n_mag - len(OFF_MAP_S) and len(off) == len(OFF_MAP_S)
        assert all(q.reason.startswith("off map") for q in off)
        for f in fixes:
            # the EKF's 3-D pseudo-fix: the error along the 3-D gradient is gone (it was
            # g . (0, 300 m, 0) / |g| = 36 m), the covariance says so and nothing else
            t = round(f.header.stamp.sec + f.header.stamp.nanosec * 1e-9)
            tl, tlo = truth[t]
            _, g = gmap.total_and_gradient(tl, tlo, 26000.0)
            u3 = g / np.linalg.norm(g)
            en = LocalFrame(tl, tlo, 26000.0).to_en(np.deg2rad(f.latitude), np.deg2rad(f.longitude))
            err3 = np.array([en[0], en[1], f.altitude - 26000.0])
            assert abs(err3 @ u3) < 0.5
            C = np.asarray(f.position_covariance).reshape(3, 3)
            w, V = np.linalg.eigh(C)
            assert abs(V[:, 0] @ u3) > 0.999 and w[1] > 1e9 and f.position_covariance_type == 3
            assert np.sqrt(w[0]) == pytest.approx(0.5 / np.linalg.norm(g), rel=0.02)   # field_sigma / |g|
        # counters on /diagnostics (the last status of each node)
        diag = _last_status(msgs)
        assert diag["good"]["off_map"] == "2" and diag["good"]["rejected_mag_nan"] == "1"
        assert diag["good"]["fixes"] == str(len(fixes))
        assert diag["bad"]["map"].startswith("refused") and "epoch_decimal_year" in diag["bad"]["map"]
        assert diag["bad"]["no_map"] == str(n_mag) and diag["bad"]["rejected_mag_nan"] == "1"
        assert not msgs["/bad/geomag/fix"]
        assert all(q.reason.startswith("no map") for q in msgs["/bad/geomag/quality"])
        # the map's epoch half a day before the flight: the implied bias (core.map_epoch eq. 2) over the
        # map at start on /diagnostics, and at each solution and stamp in geomag/quality
        epoch = map_epoch_offset(SPEC, FLIGHT_EPOCH)
        assert 0.04 < epoch.bias_mean_nT < 0.05
        assert diag["good"]["map_epoch_bias_mean_nT"] == str(round(epoch.bias_mean_nT, 4))
        assert diag["good"]["flight_epoch_decimal_year"] == str(FLIGHT_EPOCH)
        assert diag["good"]["map_brought_forward"] == "False" and diag["good"]["map_epoch_tolerance_nT"] == "0.1"
        for q in q_good:
            t = q.header.stamp.sec + q.header.stamp.nanosec * 1e-9
            assert q.map_epoch_bias_nt == pytest.approx(epoch.bias_nT(*nav_at[round(t, 1)], t), abs=1e-9)
        assert abs(float(diag["good"]["map_epoch_bias_track_nT"]) - q_good[-1].map_epoch_bias_nt) < 1e-4
    finally:
        for p in procs.values():
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        for p in procs.values():
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()


@pytest.mark.graph
def test_geomag_node_refuses_a_map_of_another_epoch_at_start(tmp_path):
    """The issue's case: a 2025.5 map at 33 S 143 E, 32 km, for a flight on
    2027.0: the node logs both fields and the implied -16.4 nT and exits 2
    before it subscribes (no map file needed: the check is the model's)."""
    spec = MapSpec(epoch_decimal_year=2025.5, alt_m=32000.0, lat_min_deg=-33.5, lat_max_deg=-25.5,
                   lon_min_deg=140.5, lon_max_deg=143.5, grid_step_deg=0.05, refine_factor=40)
    cfg = GeomagConfig.from_dict({"map": {k: getattr(spec, k) for k in spec.__dataclass_fields__},
                                  "map_file": str(tmp_path / "never_read.npz")})
    domain_id = int(os.environ["ROS_DOMAIN_ID"])         # this pytest process's own (conftest.py)
    proc = _start(tmp_path, "moved", cfg, domain_id, 2027.0)
    try:
        rc = proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    log = (tmp_path / "moved.log").read_text()
    assert rc == 2, log
    for s in ("geomag.map.epoch_decimal_year = 2025.5", "magnetometer.epoch_decimal_year = 2027",
              "-16.4 nT", "geomag.map_epoch_tolerance_nT = 0.1 nT"):
        assert s in log, log
