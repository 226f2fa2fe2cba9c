"""The IMU edge of import_data (core/importer/columns.py): a rotated IMU
imported with its mounting gives the same solution as the body-aligned one;
jittered, dropped and duplicated samples integrate to the uniform-rate
strapdown solution within the rectangle rule's own error; bad files fail
with errors naming the field."""
import math
import pathlib
import shutil
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from kfgins_files import filter_block_of, write_import_file, write_kfgins_set  # noqa: E402

from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import attitude_error_n_rad, euler_to_C_b_n  # noqa: E402
from hyper_nav_filter.core.mechanization import propagate  # noqa: E402
from hyper_nav_filter.core.nav_state import ImuSample, NavState  # noqa: E402
from hyper_nav_filter.core.params import ConfigError  # noqa: E402
from hyper_nav_filter.filter_setup import FilterSetup  # noqa: E402
from hyper_nav_filter.offline import run_offline  # noqa: E402
from hyper_nav_workbench import import_data
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.core.importer import columns
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario  # noqa: E402

RPY_DEG = (180.0, 0.0, -90.0)            # the walk's mounting


def _solve(d: pathlib.Path):
    assert import_data.main([str(d / "import.yaml"), "--out", str(d / "bag")]) == 0
    setup = FilterSetup.load(d / "bag" / "filter.yaml")
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(d / "bag")]
    return run_offline(records, setup.config, setup.initial, setup.sources, final=True)[0]


def test_rotated_imu_imported_with_its_mounting_gives_the_same_solution(tmp_path):
    plain, rotated = tmp_path / "plain", tmp_path / "rotated"
    plain.mkdir()
    sc = apply_overrides(load_scenario("default"), {"duration_s": 5.0}, plain)
    write_kfgins_set(sc, plain)
    write_import_file(plain, filter_block_of(sc))
    shutil.copytree(plain, rotated)
    # the same increments as a sensor rotated in the body would give them: v_s = C_s_b^T v_b (FRD axes)
    C_s_b = Rotation.from_euler("ZYX", RPY_DEG[::-1], degrees=True).as_matrix().T
    imu = np.loadtxt(plain / "imu.txt")
    imu[:, 1:4] = imu[:, 1:4] @ C_s_b
    imu[:, 4:7] = imu[:, 4:7] @ C_s_b
    np.savetxt(rotated / "imu.txt", imu, fmt="%.17g")
    import yaml
    doc = yaml.safe_load((rotated / "import.yaml").read_text())
    doc["imu"]["mounting"] = {"roll_pitch_yaw_deg": list(RPY_DEG)}
    (rotated / "import.yaml").write_text(yaml.safe_dump(doc))
    a, b = _solve(plain), _solve(rotated)
    assert len(a) == len(b) == 250
    worst_pos = max(np.abs(earth.position_error_enu_m(x.state.lat_rad, x.state.lon_rad, x.state.alt_m,
                                                      y.state.lat_rad, y.state.lon_rad, y.state.alt_m)).max()
                    for x, y in zip(a, b))
    worst_att = max(np.abs(attitude_error_n_rad(x.state.C_b_n, y.state.C_b_n)).max() for x, y in zip(a, b))
    assert worst_pos < 1e-9 and worst_att < 1e-12, (worst_pos, worst_att)


def test_mounting_matrix_must_be_a_rotation():
    C = columns.mounting_matrix({"mounting": {"roll_pitch_yaw_deg": [180, 0, -90]}})
    # body FRD = (-y, -x, -z) of the sensor (the original project's Euler_to_CTM)
    assert C == pytest.approx(np.array([[0, -1, 0], [-1, 0, 0], [0, 0, -1]]), abs=1e-15)
    assert columns.mounting_matrix({"mounting": {"matrix": C.tolist()}}) == pytest.approx(C)
    with pytest.raises(ConfigError, match=r"imu.mounting.matrix: not a rotation .*det = -1"):
        columns.mounting_matrix({"mounting": {"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}})
    with pytest.raises(ConfigError, match=r"imu.mounting.matrix: not a rotation \(max \|C C\^T - I\| = 0.21"):
        columns.mounting_matrix({"mounting": {"matrix": [[1.1, 0, 0], [0, 1, 0], [0, 0, 1]]}})
    with pytest.raises(ConfigError, match=r"imu.mounting.matrix: expected a 3 x 3 matrix"):
        columns.mounting_matrix({"mounting": {"matrix": [[1, 0], [0, 1]]}})
    with pytest.raises(ConfigError, match=r"imu.mounting.roll_pitch_yaw_deg: expected 3 finite numbers"):
        columns.mounting_matrix({"mounting": {"roll_pitch_yaw_deg": [180, "x", 0]}})


# ---------------------------------------------------------------- timing
def _w(t):          # a rate and a specific force that change within a sample interval (rad/s, m/s^2)
    return np.stack([0.4 * np.sin(1.3 * t), 0.3 * np.cos(0.9 * t), 0.5 + 0.2 * np.sin(2.1 * t)], axis=-1)


def _f(t):
    return np.stack([1.5 * np.sin(0.8 * t), 0.8 * np.cos(1.1 * t), 9.8 + 0.5 * np.sin(1.7 * t)], axis=-1)


def _csv(path, t):
    """A rates file as a MEMS IMU logs it: instantaneous rate samples at the stamps, g and rad/s."""
    rows = np.column_stack([t, _f(t) / 9.80665, _w(t)])
    np.savetxt(path, rows, fmt="%.17g", delimiter=",")
    return {"file": path.name, "time": {"column": 0}, "kind": "rates", "accel": {"columns": [1, 2, 3], "unit": "g"},
            "gyro": {"columns": [4, 5, 6], "unit": "rad/s"}}


def _ins(imu, t_end):
    s = NavState(float(imu.t_s[0]), math.radians(40.0), math.radians(-105.0), 1600.0, np.zeros(3),
                 euler_to_C_b_n(0.0, 0.0, 0.3))
    prev = None
    for k in range(1, len(imu.t_s)):
        if imu.t_s[k] > t_end + 1e-9:
            break
        cur = ImuSample(float(imu.t_s[k]), float(imu.t_s[k] - imu.t_s[k - 1]), imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        s = propagate(s, cur, prev)
        prev = cur
    return s


def _diff(a, b):
    return (float(np.abs(earth.position_error_enu_m(a.lat_rad, a.lon_rad, a.alt_m, b.lat_rad, b.lon_rad,
                                                    b.alt_m)).max()),
            float(np.abs(a.vel_enu_mps - b.vel_enu_mps).max()), float(np.abs(attitude_error_n_rad(a.C_b_n, b.C_b_n)).max()))


def test_jittered_dropped_and_duplicated_samples_match_the_uniform_rate_solution(tmp_path):
    T, rate = 6.0, 150.0
    rng = np.random.default_rng(7)
    t_uni = np.arange(0.0, T + 0.02, 1 / rate)
    t_jit = t_uni + rng.uniform(-1e-3, 1e-3, len(t_uni))        # +-1 ms on 6.7 ms (the walk's spacing varies so)
    t_jit[0], t_jit[-1] = t_uni[0], t_uni[-1]
    t_jit = np.delete(t_jit, 700)                                  # a dropped sample: one doubled interval
    fine = columns.imu_table(_csv(tmp_path / "fine.csv", np.arange(0.0, T + 0.02, 1 / 1500.0)), tmp_path)
    uni = columns.imu_table(_csv(tmp_path / "uni.csv", t_uni), tmp_path)
    spec = _csv(tmp_path / "jit.csv", t_jit)
    lines = (tmp_path / "jit.csv").read_text().splitlines()
    (tmp_path / "jit.csv").write_text("\n".join(lines[:300] + [lines[299]] + lines[300:]) + "\n")   # logged twice
    jit = columns.imu_table(spec, tmp_path)
    assert jit.duplicates == (301,) and len(jit.t_s) == len(t_jit)
    t_end = t_uni[-1]
    truth, s_uni, s_jit = _ins(fine, t_end), _ins(uni, t_end), _ins(jit, t_end)
    e_uni, e_jit, d = _diff(s_uni, truth), _diff(s_jit, truth), _diff(s_jit, s_uni)
    # measured over 6 s (pos m, vel m/s, att rad): uniform 150 Hz vs 1.5 kHz (0.18, 0.081, 1.7e-3), the rectangle
    # rule on sampled rates; jittered (+ a dropped and a duplicated sample) vs uniform (3.0e-3, 1.2e-3, 4.6e-5):
    # jitter and the dropped sample add 2 % to that error, nothing of their own
    assert all(j < 1.1 * u for j, u in zip(e_jit, e_uni)), (e_uni, e_jit)
    assert d[0] < 0.01 and d[1] < 0.005 and d[2] < 2e-4, d


# ---------------------------------------------------------------- bad input
def _spec(tmp_path, text):
    (tmp_path / "imu.csv").write_text(text)
    return {"file": "imu.csv", "time": {"column": 0}, "kind": "rates", "accel": {"columns": [1, 2, 3], "unit": "g"},
            "gyro": {"columns": [4, 5, 6], "unit": "rad/s"}}


def _rows(t):
    return "".join(f"{x:.3f},0,0,1,0,0,0\n" for x in t)


def test_bad_imu_files_fail_naming_the_field(tmp_path):
    good = _rows(np.arange(0, 1, 0.01))
    with pytest.raises(ConfigError, match=r"imu.accel: column 2 of .*imu.csv line 3 \(data row 3\) is not a number: "
                                          r"'abc'"):
        columns.imu_table(_spec(tmp_path, good.replace("0.020,0,0,1", "0.020,0,abc,1")), tmp_path)
    rev = _rows([0.0, 0.01, 0.02, 0.015, 0.03])
    with pytest.raises(ConfigError, match=r"imu.time: not increasing at data row 3 \(time reversal 0.02 -> 0.015"):
        columns.imu_table(_spec(tmp_path, rev), tmp_path)
    gap = _rows([0.0, 0.01, 0.02, 2.02, 2.03])
    with pytest.raises(ConfigError, match=r"imu.time: gap of 2.000 s between data rows 3 and 4 .* imu.max_gap_s = 1 s"):
        columns.imu_table(_spec(tmp_path, gap), tmp_path)
    assert len(columns.imu_table({**_spec(tmp_path, gap), "max_gap_s": 3.0}, tmp_path).t_s) == 5
    dup_other = "0.000,0,0,1,0,0,0\n0.010,0,0,1,0,0,0\n0.010,0,0,1.1,0,0,0\n0.020,0,0,1,0,0,0\n"
    with pytest.raises(ConfigError, match=r"imu.time: stamp 0.01 repeated at data rows 2 and 3 with different"):
        columns.imu_table(_spec(tmp_path, dup_other), tmp_path)
    with pytest.raises(ConfigError, match=r"imu.max_gap_s: expected a positive number"):
        columns.imu_table({**_spec(tmp_path, good), "max_gap_s": "long"}, tmp_path)
    with pytest.raises(ConfigError, match=r"imu.antenna_lever_arm_m: expected 3 numbers"):
        columns.imu_table({**_spec(tmp_path, good), "antenna_lever_arm_m": [0, 1]}, tmp_path)


# ---------------------------------------------------------------- alignment in the importer
def test_import_without_initial_attitude_aligns_on_the_gnss_velocity(tmp_path):
    """The simulated flight as KF-GINS files with no truth and no initial
    state: the importer aligns (levelling + course from the GNSS velocity
    columns, the body flies along its x axis) and starts the filter at the
    alignment epoch; its attitude against the simulator's truth there lies
    inside 3 x the alignment's own sigma. An explicit t_s without an
    attitude is refused."""
    import yaml
    from hyper_nav_filter.core.attitude import quat_xyzw_to_C
    sc = apply_overrides(load_scenario("default"), {"duration_s": 8.0}, tmp_path)
    _, _, tr = write_kfgins_set(sc, tmp_path)
    fb = filter_block_of(sc)
    t0 = fb["initial_state"]["t_s"]
    fb["initial_state"] = {}
    for k in ("init_att_sigma_arcmin", "init_vel_sigma_mps"):
        fb["config"].pop(k)
    write_import_file(tmp_path, fb)
    doc = yaml.safe_load((tmp_path / "import.yaml").read_text())
    del doc["truth"]
    doc["alignment"] = {"window_s": 5.0}
    (tmp_path / "import.yaml").write_text(yaml.safe_dump(doc))
    r = import_data.load_import(tmp_path / "import.yaml")
    al = r["alignment"] if "alignment" in r else None
    init = r["setup"]["filter"]["initial_state"]
    k = int(np.argmin(np.abs(tr.t_s + t0 - init["t_s"])))
    assert abs(tr.t_s[k] + t0 - init["t_s"]) < 1e-6 and r["imu"].t_s[0] == init["t_s"]
    phi = attitude_error_n_rad(quat_xyzw_to_C(init["q_b_enu_xyzw"]), tr.C_b_n[k])
    sigma = np.radians(np.asarray(r["setup"]["filter"]["config"]["init_att_sigma_arcmin"]) / 60.0)
    assert np.all(np.abs(phi) < 3 * sigma), (np.degrees(phi), np.degrees(sigma), al)
    assert np.asarray(init["vel_enu_mps"]) == pytest.approx(tr.vel_enu_mps[k], abs=1.0)
    doc["filter"]["initial_state"] = {"t_s": t0}
    (tmp_path / "import.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ConfigError, match="filter.initial_state.t_s: given .* without an attitude"):
        import_data.load_import(tmp_path / "import.yaml")


def test_the_applied_mounting_is_reported_as_the_imu_frames_quaternion(tmp_path):
    """``ImuTable.mounting_b_xyzw`` (the scenario's ``imu.mounting_b_xyzw``,
    base_link -> imu_link on /tf_static) is the rotation the importer applied:
    a sensor-axis vector turned by it is the body vector the table holds,
    with the body convention included (FRD files: x forward, y right, z down)."""
    text = _rows(np.arange(0, 0.1, 0.01))                # the sensor's z axis reads +1 g
    flu = columns.imu_table({**_spec(tmp_path, text), "mounting": {"roll_pitch_yaw_deg": list(RPY_DEG)}}, tmp_path)
    C_s_b = Rotation.from_euler("ZYX", RPY_DEG[::-1], degrees=True).as_matrix().T
    q = np.asarray(flu.mounting_b_xyzw)
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(Rotation.from_quat(q).as_matrix(), C_s_b, atol=1e-12)
    f_b = flu.dvel_b_mps[1] / 0.01
    np.testing.assert_allclose(Rotation.from_quat(q).apply([0.0, 0.0, 9.80665]), f_b, atol=1e-9)
    frd = columns.imu_table({**_spec(tmp_path, text), "body": "FRD"}, tmp_path)
    np.testing.assert_allclose(Rotation.from_quat(frd.mounting_b_xyzw).as_matrix(), np.diag([1.0, -1.0, -1.0]),
                               atol=1e-12)
    plain = columns.imu_table(_spec(tmp_path, text), tmp_path)
    assert plain.mounting_b_xyzw == (0.0, 0.0, 0.0, 1.0)
