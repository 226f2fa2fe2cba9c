"""A data set in the C++ peer's (KF-GINS) text formats and of its size: the
user's path of ``make bench`` (``import_data`` + ``replay_filter``) runs on it.

The peer's own semi-synthetic set (672,399 IMU epochs at 200 Hz, 3,362 GNSS
fixes at 1 Hz, a 200 Hz truth) is not on the project's machines; this one
has the same sizes, rates and formats, made with the project's own tools:
the default scenario flown for 3362 s at 200 Hz IMU and 1 Hz GNSS
(``simulate``), written as KF-GINS writes its files (FRD increments, NED,
degrees, GNSS seconds of week; a 7-column ``GNSS-RTK.txt`` of positions and
NED sigmas, as the peer's), plus an ``import.yaml`` whose filter is the 21
states of the peer (biases and scale factors) with the scenario's noise.

    python benchmarks/peer_dataset.py DIR [--duration-s 3362]

Writes ``DIR/{imu.txt, gnss.txt, truth.nav, import.yaml, peer.json}`` once
(a second call with the same size reuses the files: ``DIR/done``).
``peer.json`` holds the same filter as the peer's configuration
(``kfgins_config``: its ``kf-gins.yaml`` keys and units, written next to the
run's output folder by ``peer_yaml``), so that KF-GINS runs the same 21
states with the same noise, initial state and sigmas on the same files: one
correlation time (KF-GINS has one) = the bias correlation time of the
scenario, which also stands for the scale factors' (random constants in the
scenario: 10 h against infinity, over a 56 min set).
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

import numpy as np
import yaml

T0_SOW = 456300.0               # seconds of week of the first IMU record (the peer's data set starts there)
DURATION_S = 3362.0              # 672,400 IMU records = 672,399 increments at 200 Hz; 3,362 fixes at 1 Hz
FRD = np.array([1.0, -1.0, -1.0])


def _ned(v):
    return np.column_stack([v[:, 1], v[:, 0], -v[:, 2]])


def write(directory, duration_s: float = DURATION_S, log=print) -> pathlib.Path:
    """The files of the data set in ``directory``; returns the import file."""
    from hyper_nav_filter.core.attitude import C_b_n_to_euler
    from hyper_nav_filter.core.initial_state import state_values
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_workbench.graph import apply_overrides

    d = pathlib.Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    stamp = d / "done"
    if stamp.exists() and stamp.read_text().strip() == f"{duration_s:g}" and (d / "peer.json").exists():
        return d / "import.yaml"
    sc = apply_overrides(load_scenario("default"), {"duration_s": float(duration_s), "imu.rate_hz": 200.0,
                                                    "gnss.rate_hz": 1.0}, d)
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    g = simulate.gnss_stream(sc, traj)
    t_imu = np.concatenate([[0.0], imu.t_s])                # row 0 starts the time line at t = 0
    dth = np.vstack([np.zeros(3), imu.dtheta_b_rad]) * FRD
    dv = np.vstack([np.zeros(3), imu.dvel_b_mps]) * FRD
    np.savetxt(d / "imu.txt", np.column_stack([t_imu + T0_SOW, dth, dv]), fmt="%.17g")
    sig = np.tile(np.asarray(sc["gnss.pos_sigma_enu_m"], float)[[1, 0, 2]], (len(g.t_s), 1))
    np.savetxt(d / "gnss.txt", np.column_stack([g.t_s + T0_SOW, np.rad2deg(g.lat_rad), np.rad2deg(g.lon_rad),
                                                g.alt_m, sig]), fmt="%.17g")
    tr = traj.truth(t_imu)
    rph = np.rad2deg(np.column_stack(C_b_n_to_euler(tr.C_b_n)))       # a stack: scipy, vectorised
    np.savetxt(d / "truth.nav", np.column_stack([np.zeros(len(t_imu)), t_imu + T0_SOW, np.rad2deg(tr.lat_rad),
                                                 np.rad2deg(tr.lon_rad), tr.alt_m, _ned(tr.vel_enu_mps), rph]),
               fmt="%.17g")
    cfg = sc.filter_config().as_dict()
    cfg["state_blocks"] = ["att", "vel", "pos", "bg", "ba", "sg", "sa"]
    init = state_values(sc.filter_initial_state())
    init["t_s"] = T0_SOW
    doc = {"preset": "kfgins", "imu": {"file": "imu.txt"}, "gnss": {"file": "gnss.txt"},
           "truth": {"file": "truth.nav"}, "filter": {"config": cfg, "initial_state": init},
           "report": {"skip_s": 30.0}}
    (d / "import.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    nav0 = sc.filter_initial_state()
    (d / "peer.json").write_text(json.dumps(kfgins_config(cfg, nav0, T0_SOW), indent=1))
    stamp.write_text(f"{duration_s:g}\n")
    log(f"[peer_dataset] {d}: {len(imu.t_s)} IMU epochs, {len(g.t_s)} GNSS fixes, {len(t_imu)} truth rows")
    return d / "import.yaml"


def kfgins_config(cfg: dict, nav0, t0_sow: float) -> dict:
    """The KF-GINS configuration (``kf-gins.yaml`` keys, its units and
    frames: NED, FRD, deg, deg/h, mGal, ppm) of the filter ``cfg``
    (``FilterConfig.as_dict``) from the initial state ``nav0`` (NavState):
    the inverse of ``importer.kfgins.filter_block``."""
    from hyper_nav_filter.core import units
    from hyper_nav_filter.core.attitude import C_b_n_to_euler

    def enu_to_ned(v):
        return [float(v[1]), float(v[0]), float(v[2])]

    def vec(x):
        return [float(a) for a in np.asarray(x, float)]
    v = np.asarray(nav0.vel_enu_mps, float)
    return {
        "imudatalen": 7, "imudatarate": 200, "starttime": float(t0_sow), "endtime": -1,
        "initpos": [float(np.rad2deg(nav0.lat_rad)), float(np.rad2deg(nav0.lon_rad)), float(nav0.alt_m)],
        "initvel": [float(v[1]), float(v[0]), float(-v[2])],
        "initatt": vec(np.rad2deg(C_b_n_to_euler(nav0.C_b_n))),
        "initgyrbias": [0.0] * 3, "initaccbias": [0.0] * 3, "initgyrscale": [0.0] * 3, "initaccscale": [0.0] * 3,
        "initposstd": enu_to_ned(cfg["init_pos_sigma_m"]),
        "initvelstd": enu_to_ned(cfg["init_vel_sigma_mps"]),
        "initattstd": enu_to_ned(np.asarray(cfg["init_att_sigma_arcmin"], float) / 60.0),
        "imunoise": {
            "arw": vec(cfg["gyro_arw_deg_per_sqrt_hr"]),
            "vrw": vec(units.ug_per_sqrt_hz(cfg["accel_vrw_ug_per_sqrt_hz"]) * 60.0),     # m/s/sqrt(s) -> /sqrt(h)
            "gbstd": vec(cfg["gyro_bias_sigma_deg_per_hr"]),
            "abstd": vec(units.ug(cfg["accel_bias_sigma_ug"]) * 1e5),                      # m/s^2 -> mGal
            "gsstd": vec(cfg["gyro_scale_factor_sigma_ppm"]),
            "asstd": vec(cfg["accel_scale_factor_sigma_ppm"]),
            "corrtime": float(cfg["gyro_bias_tau_s"]) / 3600.0,
        },
        "antlever": vec(np.asarray(cfg["antenna_lever_arm_b_m"], float) * FRD),
    }


def peer_yaml(data_dir, out_dir) -> pathlib.Path:
    """``out_dir/kf-gins.yaml``: the data set's ``peer.json`` with its files
    (absolute paths) and ``out_dir`` as the peer's output folder."""
    d, out = pathlib.Path(data_dir).resolve(), pathlib.Path(out_dir).resolve()
    out.mkdir(parents=True, exist_ok=True)
    doc = {"imupath": str(d / "imu.txt"), "gnsspath": str(d / "gnss.txt"), "outputpath": str(out),
           **json.loads((d / "peer.json").read_text())}
    path = out / "kf-gins.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dir")
    ap.add_argument("--duration-s", type=float, default=DURATION_S)
    a = ap.parse_args(argv)
    print(write(a.dir, a.duration_s))
    return 0


if __name__ == "__main__":
    sys.exit(main())
