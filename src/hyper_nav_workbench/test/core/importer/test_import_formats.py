"""Formats a u-blox/RTKLIB user has, each with a small file written here:
the RTKLIB .pos solution as the GNSS input (``%`` header, date and time
columns, Q to select and weight, sdn/sde/sdu, N-E-U velocities), any axis
order of velocity frames, an IMU millisecond counter through an RTKLIB
time-tag file or a counter table, an IMU time offset, unknown fields refused
with a did-you-mean, disjoint time axes named, --write-nav at the antenna."""
import datetime as dt
import pathlib
import sys

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from kfgins_files import FRD, filter_block_of  # noqa: E402

from hyper_nav_gnss import earth
from hyper_nav_filter.core.params import ConfigError  # noqa: E402
from hyper_nav_workbench import import_data, replay_filter
from hyper_nav_sim.core import simulate  # noqa: E402
from hyper_nav_workbench.core.importer import columns, rtklib_pos, time_tags
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario  # noqa: E402

GPST0 = 2_000_000_000.0 - 315964800.0 + 0.25     # a GPST epoch (s since 1980-01-06) of the first IMU record
EPOCH = dt.datetime(1980, 1, 6)

POS_HEADER = """% program   : RTKLIB ver.demo5 b34k
% inp file  : rover.obs
% pos mode  : Kinematic
%
%  GPST                  latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio    vn(m/s)    ve(m/s)    vu(m/s)      sdvn     sdve     sdvu    sdvne    sdveu    sdvun
"""


def gpst_text(t_s: float) -> str:
    d = EPOCH + dt.timedelta(seconds=t_s)
    return d.strftime("%Y/%m/%d %H:%M:%S.") + f"{d.microsecond // 1000:03d}"


def pos_line(t, lat_deg, lon_deg, h, q, sig_neu, vel_neu, vsig_neu):
    return (f"{gpst_text(t)} {lat_deg:14.9f} {lon_deg:14.9f} {h:10.4f} {q:3d} {12:3d} "
            f"{sig_neu[0]:8.4f} {sig_neu[1]:8.4f} {sig_neu[2]:8.4f} 0.0000 0.0000 0.0000 0.00 999.9 "
            f"{vel_neu[0]:10.5f} {vel_neu[1]:10.5f} {vel_neu[2]:10.5f} {vsig_neu[0]:8.5f} {vsig_neu[1]:8.5f} "
            f"{vsig_neu[2]:8.5f} 0.0 0.0 0.0")


def test_a_pos_file_reads_with_its_header_dates_quality_and_neu_velocities(tmp_path):
    lines = [pos_line(GPST0 + 0.25 * k, 45.0 + 1e-7 * k, 7.0, 300.0, q, (0.01, 0.02, 0.03), (1.0, 2.0, 0.5),
                      (0.01, 0.02, 0.04)) for k, q in enumerate([1, 1, 2, 5, 1])]
    (tmp_path / "drive.pos").write_text(POS_HEADER + "\n".join(lines) + "\n")
    tab, text = rtklib_pos.fix_table({"file": "drive.pos", "quality": [1, 2], "sigma_scale": {2: 4.0}}, tmp_path)
    assert tab.t_s == pytest.approx(GPST0 + np.array([0.0, 0.25, 0.5, 1.0]), abs=1e-6)
    assert np.rad2deg(tab.lat_rad[1]) == pytest.approx(45.0000001, abs=1e-10)
    assert tab.pos_sigma_enu_m[0] == pytest.approx([0.02, 0.01, 0.03])         # sdn sde sdu -> E N U
    assert tab.pos_sigma_enu_m[2] == pytest.approx([0.08, 0.04, 0.12])         # Q=2 weighted x 4
    assert tab.vel_enu_mps[0] == pytest.approx([2.0, 1.0, 0.5])                # vn ve vu -> E N U
    assert tab.vel_sigma_enu_mps[2] == pytest.approx([0.08, 0.04, 0.16])
    assert "Q=1 fix 3 (sigma x 1)" in text and "Q=2 float 1 (sigma x 4)" in text and "dropped Q=5 single 1" in text
    with pytest.raises(ConfigError, match="gnss.qualty: unknown field; did you mean 'quality'"):
        rtklib_pos.fix_table({"file": "drive.pos", "qualty": [1]}, tmp_path)
    with pytest.raises(ConfigError, match=r"gnss.quality: no epoch of Q \[4\]"):
        rtklib_pos.fix_table({"file": "drive.pos", "quality": [4]}, tmp_path)


def test_any_axis_order_of_a_velocity_frame(tmp_path):
    (tmp_path / "g.txt").write_text("0 45 7 300 1 2 3\n1 45 7 300 1 2 3\n")
    base = {"file": "g.txt", "time": {"column": 0}, "lat": {"column": 1}, "lon": {"column": 2}, "alt": {"column": 3}}
    for frame, enu in (("NEU", [2, 1, 3]), ("NED", [2, 1, -3]), ("ENU", [1, 2, 3]), ("NWU", [-2, 1, 3]),
                       ("UEN", [2, 3, 1]), ("SED", [2, -1, -3])):
        tab = columns.fix_table({**base, "velocity": {"columns": [4, 5, 6], "frame": frame}}, tmp_path, "gnss")
        assert tab.vel_enu_mps[0] == pytest.approx(enu), frame
    with pytest.raises(ConfigError, match="gnss.velocity.frame: unknown frame 'NEN'"):
        columns.fix_table({**base, "velocity": {"columns": [4, 5, 6], "frame": "NEN"}}, tmp_path, "gnss")


def _imu_rows(n=5, dt_s=0.01):
    return np.column_stack([np.arange(n) * dt_s, np.tile([1e-4, 2e-4, 3e-4, 0.0, 0.0, 0.098], (n, 1))])


def test_an_imu_millisecond_counter_through_an_rtklib_time_tag_file(tmp_path):
    tick_f = 4_294_960_000                                     # wraps past 2^32 within the file
    rows = _imu_rows()
    ticks = (tick_f + 1500 + np.round(rows[:, 0] * 1000)) % 2 ** 32
    np.savetxt(tmp_path / "imu.txt", np.column_stack([ticks, rows[:, 1:]]), fmt="%.10g")
    time_tags.write_tag(tmp_path / "rover.ubx.tag", GPST0, tick_f, [(tick_f + 10, 0), (tick_f + 1010, 1024)])
    tag = time_tags.read_tag(tmp_path / "rover.ubx.tag")
    assert tag.version.startswith("TIMETAG RTKLIB demo5") and tag.tick_f_ms == tick_f and len(tag.ticks_ms) == 2
    assert tag.t_start_gpst_s == pytest.approx(GPST0, abs=1e-6)
    spec = {"file": "imu.txt", "time": {"column": 0, "unit": "ms", "tag": "rover.ubx.tag", "offset_s": -0.002},
            "gyro": {"columns": [1, 2, 3]}, "accel": {"columns": [4, 5, 6]}}
    imu = columns.imu_table(spec, tmp_path)
    assert imu.t_s == pytest.approx(GPST0 + 1.5 - 0.002 + rows[:, 0], abs=1e-6)
    # any counter: a (counter, time) table, linear between its rows
    np.savetxt(tmp_path / "map.csv", [[0, 100.0], [1_000_000, 110.0]], delimiter=",")
    np.savetxt(tmp_path / "imu2.txt", np.column_stack([rows[:, 0] * 1e5, rows[:, 1:]]), fmt="%.10g")
    imu2 = columns.imu_table({**spec, "file": "imu2.txt", "time": {"column": 0, "map": {"file": "map.csv"}}},
                             tmp_path)
    assert imu2.t_s == pytest.approx(100.0 + rows[:, 0], abs=1e-9)
    (tmp_path / "x.tag").write_bytes(b"not a tag file" * 10)
    with pytest.raises(ConfigError, match="imu.time.tag: .* is not an RTKLIB time-tag file"):
        columns.imu_table({**spec, "time": {"column": 0, "unit": "ms", "tag": "x.tag"}}, tmp_path)


@pytest.mark.parametrize("where, bad, hint", [
    (("imu",), "time_offset_s", "unknown field"),
    (("imu", "time"), "offset", "did you mean 'offset_s'"),
    (("gnss",), "quality", "unknown field"),                 # not a field of a column-map GNSS file
    ((), "prest", "did you mean 'preset'"),
    (("report",), "skip", "did you mean 'skip_s'"),
])
def test_unknown_fields_of_an_import_description_are_refused(tmp_path, where, bad, hint):
    doc = _tiny_import(tmp_path)
    node = doc
    for k in where:
        node = node[k]
    node[bad] = 1
    (tmp_path / "import.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ConfigError, match=rf"{'.'.join(where + (bad,)) if where else bad}: unknown field.*"
                                          rf"|{bad}.*{hint}") as exc:
        import_data.load_import(tmp_path / "import.yaml")
    assert hint in str(exc.value)


def _tiny_import(tmp_path):
    rows = _imu_rows(400)
    np.savetxt(tmp_path / "imu.txt", rows, fmt="%.10g")
    np.savetxt(tmp_path / "gnss.txt", [[t, 45.0, 7.0, 300.0, 1.0, 1.0, 1.0] for t in (0.5, 1.5, 2.5)], fmt="%.10g")
    return {"imu": {"file": "imu.txt", "time": {"column": 0}, "gyro": {"columns": [1, 2, 3]},
                    "accel": {"columns": [4, 5, 6]}},
            "gnss": {"file": "gnss.txt", "time": {"column": 0}, "lat": {"column": 1}, "lon": {"column": 2},
                     "alt": {"column": 3}, "sigma": {"columns": [4, 5, 6]}},
            "filter": {"initial_state": {"lat_deg": 45.0, "lon_deg": 7.0, "alt_m": 300.0,
                                         "roll_pitch_heading_deg": [0.0, 0.0, 0.0]}},
            "report": {"skip_s": 0.0}}


def test_disjoint_imu_and_gnss_time_axes_are_named(tmp_path):
    doc = _tiny_import(tmp_path)
    doc["imu"]["time"]["offset_s"] = 1.3e9                     # a GPST IMU against a seconds-of-day GNSS
    (tmp_path / "import.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ConfigError, match="imu.time and gnss.time: disjoint time axes: IMU 1300000000.000 to"):
        import_data.load_import(tmp_path / "import.yaml")


@pytest.fixture(scope="module")
def pos_import(tmp_path_factory):
    """A simulated flight written as a user of RTKLIB has it: IMU increments (FRD) stamped with a logger's ms
    tick + an RTKLIB time-tag file, the GNSS as an RTKLIB .pos (2 cm fixes, N-E-U velocities, a few floats)."""
    d = tmp_path_factory.mktemp("rtklib")
    sc = apply_overrides(load_scenario("default"), {"duration_s": 20.0, "gnss.pos_sigma_enu_m": [0.02, 0.02, 0.03],
                                                    "gnss.vel_sigma_enu_mps": [0.02, 0.02, 0.02],
                                                    "gnss.antenna_lever_arm_b_m": [1.0, 0.5, -0.3]}, d)
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    g = simulate.gnss_stream(sc, traj)
    tick_f = 123_456
    t_imu = np.concatenate([[0.0], imu.t_s])
    ticks = tick_f + 2000 + np.round(t_imu * 1000).astype(np.int64)      # IMU starts 2 s after the tag file
    np.savetxt(d / "imu.txt", np.column_stack([ticks, np.vstack([np.zeros(3), imu.dtheta_b_rad]) * FRD,
                                               np.vstack([np.zeros(3), imu.dvel_b_mps]) * FRD]), fmt="%.17g")
    time_tags.write_tag(d / "imu.tag", GPST0 - 2.0, tick_f)
    q = np.where(np.arange(len(g.t_s)) % 17 == 5, 2, 1)
    s = np.asarray(sc["gnss.pos_sigma_enu_m"], float)
    vs = np.asarray(sc["gnss.vel_sigma_enu_mps"], float)
    lines = [pos_line(GPST0 + g.t_s[k], np.rad2deg(g.lat_rad[k]), np.rad2deg(g.lon_rad[k]), g.alt_m[k], int(q[k]),
                      (s[1], s[0], s[2]), (g.vel_enu_mps[k, 1], g.vel_enu_mps[k, 0], g.vel_enu_mps[k, 2]),
                      (vs[1], vs[0], vs[2])) for k in range(len(g.t_s))]
    (d / "drive.pos").write_text(POS_HEADER + "\n".join(lines) + "\n")
    block = filter_block_of(sc)
    block["initial_state"]["t_s"] = GPST0
    block["config"]["antenna_lever_arm_b_m"] = [1.0, 0.5, -0.3]
    doc = {"preset": "rtklib",
           "imu": {"file": "imu.txt", "time": {"column": 0, "unit": "ms", "tag": "imu.tag"}, "body": "FRD",
                   "gyro": {"columns": [1, 2, 3], "unit": "rad"}, "accel": {"columns": [4, 5, 6], "unit": "m/s"}},
           "gnss": {"file": "drive.pos", "quality": [1, 2], "sigma_scale": {2: 3.0}},
           "filter": block, "report": {"skip_s": 5.0}}
    (d / "import.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    return sc, d, traj, g


def test_an_rtklib_pos_drives_the_filter_through_import_and_replay(pos_import, capsys):
    sc, d, traj, g = pos_import
    assert import_data.main([str(d / "import.yaml"), "--out", str(d / "bag")]) == 0
    text = capsys.readouterr().out
    assert "RTKLIB .pos drive.pos: kept Q=1 fix" in text and "(sigma x 3)" in text
    assert "IMU noise: not measured (no static interval" in text   # a flight from the first second: said so
    imported = import_data.load_import(d / "import.yaml")
    assert imported["imu"].t_s[0] == pytest.approx(GPST0, abs=1e-6)
    assert imported["gnss"].vel_enu_mps[3] == pytest.approx(g.vel_enu_mps[3], abs=1e-5)
    nav_imu, nav_ant = d / "imu.nav", d / "ant.nav"
    replay_filter.main([str(d / "bag"), "--write-nav", str(nav_imu)])
    replay_filter.main([str(d / "bag"), "--write-nav", str(nav_ant), "--write-nav-at", "antenna"])
    text = capsys.readouterr().out
    assert "per source (filter updates" in text and "gnss_pos" in text
    a, b = np.loadtxt(nav_imu), np.loadtxt(nav_ant)
    # the antenna written is the IMU position + C_b_n l_b; the antenna fixes agree with it to the fixes' noise
    d_enu = earth.position_error_enu_m(np.deg2rad(b[:, 2]), np.deg2rad(b[:, 3]), b[:, 4], np.deg2rad(a[:, 2]),
                                       np.deg2rad(a[:, 3]), a[:, 4])
    assert np.linalg.norm(d_enu, axis=1) == pytest.approx(np.linalg.norm([1.0, 0.5, -0.3]), abs=2e-3)
    k = np.searchsorted(b[:, 1], GPST0 + g.t_s[100])
    e = earth.position_error_enu_m(np.deg2rad(b[k, 2]), np.deg2rad(b[k, 3]), b[k, 4], g.lat_rad[100], g.lon_rad[100],
                                   g.alt_m[100])
    assert np.linalg.norm(e[:2]) < 0.1, e
