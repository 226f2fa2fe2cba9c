"""Real data in: KF-GINS text files (written here from a simulated flight,
FRD body, NED, degrees, seconds of week) -> import_data -> bag ->
replay_filter. The imported run must reproduce the native run of the same
data (every conversion of frame, unit and time is exact up to the text
files' 17 digits), and replay_filter scores it against the truth file and
writes the KF-GINS result formats."""
import sys
import pathlib

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from kfgins_files import T0_SOW, filter_block_of, write_import_file, write_kfgins_set  # noqa: E402

from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import attitude_error_n_rad  # noqa: E402
from hyper_nav_filter.core.params import ConfigError  # noqa: E402
from hyper_nav_filter.filter_setup import FilterSetup  # noqa: E402
from hyper_nav_filter.offline import run_offline  # noqa: E402
from hyper_nav_workbench import import_data, offline_fly, replay_filter
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario  # noqa: E402

DURATION_S = 10.0


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    d = tmp_path_factory.mktemp("kfgins")
    sc = apply_overrides(load_scenario("default"), {"duration_s": DURATION_S}, d)
    write_kfgins_set(sc, d)
    write_import_file(d, filter_block_of(sc), report={"skip_s": 5.0})
    assert import_data.main([str(d / "import.yaml"), "--out", str(d / "bag")]) == 0
    native, _, traj, _ = offline_fly.fly(sc, sc.filter_config())
    return sc, d, native, traj


def test_imported_kfgins_files_reproduce_the_native_run(imported):
    sc, d, native, traj = imported
    setup = FilterSetup.load(d / "bag" / "filter.yaml")
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(d / "bag")]
    assert {t for t, _ in records} == {"/imu/data_raw", "/gnss/fix", "/gnss/vel", "/truth/state"}
    sols, eng = run_offline(records, setup.config, setup.initial, setup.sources, final=True)
    assert eng.counters["imu_accepted"] == 500 and eng.counters["gnss_pos_received"] == 100
    assert len(sols) == len(native) == 500
    worst = {"pos": 0.0, "vel": 0.0, "att": 0.0}
    for a, b in zip(sols, native):
        assert a.t_s - T0_SOW == pytest.approx(b.t_s, abs=1e-6)
        worst["pos"] = max(worst["pos"], np.abs(earth.position_error_enu_m(
            a.state.lat_rad, a.state.lon_rad, a.state.alt_m, b.state.lat_rad, b.state.lon_rad, b.state.alt_m)).max())
        worst["vel"] = max(worst["vel"], np.abs(a.state.vel_enu_mps - b.state.vel_enu_mps).max())
        worst["att"] = max(worst["att"], np.abs(attitude_error_n_rad(a.state.C_b_n, b.state.C_b_n)).max())
    # measured: 5e-8 m, 5e-12 m/s, 3e-15 rad (stamps near 456300 s: increments recovered to ~1e-10)
    assert worst["pos"] < 1e-5 and worst["vel"] < 1e-8 and worst["att"] < 1e-10, worst


def test_replay_filter_scores_against_the_truth_file_and_writes_kfgins_formats(imported, capsys):
    sc, d, native, traj = imported
    nav_out, std_out = d / "out.nav", d / "out_std.txt"
    assert replay_filter.main([str(d / "bag"), "--truth", str(d / "truth.nav"), "--write-nav", str(nav_out),
                               "--write-std", str(std_out)]) == 0
    text = capsys.readouterr().out
    assert "accuracy after t >= 5 s" in text
    # the same figures as the native run scored against the simulator's truth
    t, e = offline_fly.per_axis_errors(native, traj, t_from=5.0)
    pos_rms = float(np.sqrt(np.mean(np.sum(e["pos"] ** 2, axis=1))))
    line = next(ln for ln in text.splitlines() if ln.startswith("position"))
    assert float(line.split()[5]) == pytest.approx(pos_rms, abs=2e-3)
    nav = np.loadtxt(nav_out)
    assert nav.shape == (500, 11) and np.all(nav[:, 0] == 0.0)
    truth = np.loadtxt(d / "truth.nav")
    k = np.searchsorted(truth[:, 1], nav[:, 1])
    # north velocity and heading columns in KF-GINS order, against the truth file
    assert np.abs(nav[:, 5] - truth[k, 5]).max() < 0.5 and np.abs(nav[:, 10] - truth[k, 10]).max() < 0.1
    std = np.loadtxt(std_out)
    assert std.shape == (500, 22)
    assert std[0, 1:4] == pytest.approx([5.0, 5.0, 10.0], rel=1e-4)       # N E D from init_pos_sigma_m (E N U)
    assert np.all(std[:, 10:16] > 0) and np.all(np.isnan(std[:, 16:]))    # no scale-factor blocks: NaN
    assert np.all(std[-1, 1:4] < std[0, 1:4])


KFGINS_CONFIG = {   # the values of KF-GINS's demo dataset configuration
    "imupath": "", "gnsspath": "", "outputpath": "", "imudatalen": 7, "imudatarate": 200,
    "starttime": 456300, "endtime": -1,
    "initpos": [30.4447873701, 114.4718632047, 20.899], "initvel": [0.0, 0.0, 0.0],
    "initatt": [0.85421502, -2.03480295, 185.70235133],
    "initgyrbias": [0, 0, 0], "initaccbias": [0, 0, 0], "initgyrscale": [0, 0, 0], "initaccscale": [0, 0, 0],
    "initposstd": [0.005, 0.004, 0.008], "initvelstd": [0.003, 0.004, 0.004], "initattstd": [0.003, 0.003, 0.023],
    "imunoise": {"arw": [0.003, 0.003, 0.003], "vrw": [0.03, 0.03, 0.03], "gbstd": [0.027, 0.027, 0.027],
                 "abstd": [15.0, 15.0, 15.0], "gsstd": [300.0, 300.0, 300.0], "asstd": [300.0, 300.0, 300.0],
                 "corrtime": 4.0},
    "antlever": [0.136, -0.301, -0.184],
}


def test_kfgins_configuration_becomes_the_filter_setup_in_our_units():
    from hyper_nav_workbench.core.importer import kfgins
    block = kfgins.filter_block({**KFGINS_CONFIG, "initbgstd": [1.0, 1.0, 1.0], "initaccbias": [100.0, 0.0, 50.0]},
                                t0_s=456300.0)
    setup = FilterSetup.from_dict({"filter": block})
    c = setup.config
    assert c.layout.dim == 21 and c.gate_probability == 1.0
    assert c.accel_vrw_ug_per_sqrt_hz == pytest.approx((50.98581,) * 3, rel=1e-6)   # 0.03 m/s/sqrt(h) / 60 / 9.80665e-6
    assert c.accel_bias_sigma_ug == pytest.approx((15.2957,) * 3, rel=1e-5)         # 15 mGal = 1.5e-4 m/s^2
    assert c.gyro_bias_tau_s == c.accel_scale_factor_tau_s == 14400.0
    assert c.antenna_lever_arm_b_m == pytest.approx((0.136, 0.301, 0.184))          # FRD -> FLU
    assert c.init_pos_sigma_m == pytest.approx((0.004, 0.005, 0.008))               # NED -> ENU
    sig = np.sqrt(np.diag(c.initial_covariance()))
    assert sig[c.layout.sl("bg")] == pytest.approx(np.deg2rad(1.0) / 3600.0)        # initbgstd, not gbstd
    assert sig[c.layout.sl("ba")] == pytest.approx(1.5e-4)                          # default: abstd
    assert sig[c.layout.sl("sg")] == pytest.approx(300e-6)
    s = setup.initial
    assert s.t_s == 456300.0 and np.rad2deg(s.lat_rad) == pytest.approx(30.4447873701)
    from hyper_nav_filter.core.initial_state import euler_deg
    assert euler_deg(s) == pytest.approx((0.85421502, -2.03480295, 185.70235133), abs=1e-9)
    assert s.accel_bias_b_mps2 == pytest.approx([100e-5, 0.0, -50e-5])             # mGal, FRD -> FLU


def test_generic_csv_with_a_column_map_rates_units_and_frames(tmp_path):
    """Rates in deg/s and g, time in ms, body RFU (x right, y forward, z up),
    comma-separated with a header: increments in FLU, SI."""
    from hyper_nav_workbench.core.importer import columns
    rows = ["time_ms,gx,gy,gz,ax,ay,az"] + [f"{10 * k},{0.5},{1.0},{-2.0},{0.1},{0.0},{1.0}" for k in range(5)]
    (tmp_path / "imu.csv").write_text("\n".join(rows) + "\n")
    spec = {"file": "imu.csv", "skip_rows": 1, "time": {"column": 0, "unit": "ms"}, "kind": "rates", "body": "RFU",
            "gyro": {"columns": [1, 2, 3], "unit": "deg/s"}, "accel": {"columns": [4, 5, 6], "unit": "g"}}
    imu = columns.imu_table(spec, tmp_path)
    assert imu.t_s == pytest.approx([0.0, 0.01, 0.02, 0.03, 0.04])
    # RFU (r, f, u) -> FLU (f, -r, u); increment = rate x 0.01 s
    assert imu.dtheta_b_rad[1] == pytest.approx(np.deg2rad([1.0, -0.5, -2.0]) * 0.01)
    assert imu.dvel_b_mps[1] == pytest.approx(np.array([0.0, -0.1, 1.0]) * 9.80665 * 0.01)
    with pytest.raises(ConfigError, match=r"imu.gyro.unit: unknown unit 'rad/min'"):
        columns.imu_table({**spec, "gyro": {"columns": [1, 2, 3], "unit": "rad/min"}}, tmp_path)
    with pytest.raises(ConfigError, match=r"imu.accel.columns: \[4, 5, 9\] outside the file's 7 columns"):
        columns.imu_table({**spec, "accel": {"columns": [4, 5, 9], "unit": "g"}}, tmp_path)
    (tmp_path / "bad.csv").write_text("0,0,0,0,0,0,0\n0.02,0,0,0,0,0,0\n0.01,0,0,0,0,0,0\n")
    with pytest.raises(ConfigError, match="imu.time: not increasing at data row 2"):
        columns.imu_table({**spec, "file": "bad.csv", "skip_rows": 0, "time": {"column": 0}}, tmp_path)


def test_import_errors_name_the_field(imported, tmp_path):
    d = imported[1]
    doc = yaml.safe_load((d / "import.yaml").read_text())
    doc["filter"]["config"]["accel_vrw_mps_per_sqrt_hr"] = 0.03      # and accel_vrw_ug_per_sqrt_hz already given
    (d / "twice.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ConfigError, match="accel_vrw_mps_per_sqrt_hr: the same quantity as accel_vrw_ug_per_sqrt_hz"):
        import_data.load_import(d / "twice.yaml")
    doc = yaml.safe_load((d / "import.yaml").read_text())
    del doc["filter"]["initial_state"]["lat_deg"]
    del doc["truth"]
    (d / "nolat.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ConfigError, match="filter.initial_state.lat_deg: required"):
        import_data.load_import(d / "nolat.yaml")
