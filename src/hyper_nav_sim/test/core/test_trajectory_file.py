"""A user's trajectory file as the truth (core.trajectory_file): the
default flight written at 10 Hz (quaternion or roll/pitch/heading columns,
renamed columns and units as a 6-DOF tool writes them), flown by a scenario
with ``trajectory_file:``, gives the built-in flight's IMU increments within
the interpolation error measured on this flight (50 Hz increments over
300 s: |d theta| <= 2.7e-5 rad, |d v| <= 8.1e-4 m/s per 20 ms, from a
10 Hz file; 0.06 % of the largest dv), positions within 1 cm; so does a
nav_msgs/Odometry bag (local ENU pose at an origin, body twist); an
inconsistent file is refused naming the epoch."""
import csv

import numpy as np
import pytest
import yaml

from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.scenario import ScenarioError, load_scenario, load_with_settings
from hyper_nav_sim.core.trajectory_file import FileTrajectory, write_csv


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    d = tmp_path_factory.mktemp("traj")
    sc = load_with_settings("default", [])
    write_csv(d / "flight.csv", sc.trajectory(), np.arange(0.0, 300.0 + 1e-9, 0.1))
    return sc, d


def _rewrite(src, dst, rename=None, edit=None):
    rows = list(csv.reader(open(src)))
    if rename:
        rows[0] = [rename.get(h, h) for h in rows[0]]
    if edit:
        edit(rows)
    with open(dst, "w", newline="") as fh:
        csv.writer(fh).writerows(rows)


def test_round_trip_gives_the_built_in_imu(flight, tmp_path):
    sc, d = flight
    # a 6-DOF tool's names, and milliseconds
    def ms(rows):
        for r in rows[1:]:
            r[0] = repr(float(r[0]) * 1000.0)
    _rewrite(d / "flight.csv", tmp_path / "user.csv", {"t": "time_ms", "lat": "latitude", "qw": "q0"}, ms)
    data = dict(load_scenario("default").data)
    data.pop("start")
    data.pop("maneuvers")
    data["trajectory_file"] = {"path": "user.csv", "columns": {"t": "time_ms", "lat": "latitude", "qw": "q0"},
                               "units": {"t": "ms"}}
    (tmp_path / "user.yaml").write_text(yaml.safe_dump(data))
    user = load_scenario(str(tmp_path / "user.yaml"))
    a = simulate.imu_stream(sc, sc.trajectory(), error_free=True)
    b = simulate.imu_stream(user, user.trajectory(), error_free=True)
    assert np.abs(a.dtheta_b_rad - b.dtheta_b_rad).max() < 3e-5
    assert np.abs(a.dvel_b_mps - b.dvel_b_mps).max() < 9e-4
    # and the errors are interpolation, not a frame slip: their RMS is far below the maxima
    assert np.sqrt(np.mean((a.dvel_b_mps - b.dvel_b_mps) ** 2)) < 1e-4
    t = np.linspace(0.0, 300.0, 777)
    ta, tb = sc.trajectory().truth(t), user.trajectory().truth(t)
    assert np.abs(ta.alt_m - tb.alt_m).max() < 0.01
    assert np.abs(ta.lat_rad - tb.lat_rad).max() * 6.4e6 < 0.01


def test_euler_columns_fly_the_same(flight, tmp_path):
    sc, d = flight
    write_csv(tmp_path / "euler.csv", sc.trajectory(), np.arange(0.0, 60.0 + 1e-9, 0.1), quaternion=False)
    ft = FileTrajectory.from_config({"path": str(tmp_path / "euler.csv")})
    t = np.arange(1, 3001) / 50.0
    a, b = sc.trajectory().imu_increments(t, 0.02), ft.imu_increments(t, 0.02)
    assert np.abs(a[1] - b[1]).max() < 9e-4


def test_inconsistent_files_are_refused_naming_the_epoch(flight, tmp_path):
    _, d = flight

    def bad_velocity(rows):
        rows[1 + 1234][5] = repr(float(rows[1 + 1234][5]) + 20.0)      # vn at t = 123.4 s
    _rewrite(d / "flight.csv", tmp_path / "v.csv", edit=bad_velocity)
    with pytest.raises(ValueError, match=r"position and velocity disagree between t = 123\.300 s and 123\.400 s"):
        FileTrajectory.from_config({"path": str(tmp_path / "v.csv")})

    def wxyz(rows):                                                     # quaternion written w, x, y, z
        for r in rows[1:]:
            r[7:11] = [r[10], r[7], r[8], r[9]]
    _rewrite(d / "flight.csv", tmp_path / "q.csv", edit=wxyz)
    with pytest.raises(ValueError, match=r"attitude and velocity disagree at t = 0\.000 s"):
        FileTrajectory.from_config({"path": str(tmp_path / "q.csv")})

    def hole(rows):
        rows[50][3] = "nan"
    _rewrite(d / "flight.csv", tmp_path / "n.csv", edit=hole)
    with pytest.raises(ValueError, match=r"non-finite alt at t = 4\.900 s"):
        FileTrajectory.from_config({"path": str(tmp_path / "n.csv")})
    with pytest.raises(ValueError, match="did you mean 'columns'"):
        FileTrajectory.from_config({"path": "x.csv", "colums": {}})


def _odometry_bag(path, traj, t_s, origin):
    """The flight as nav_msgs/Odometry: pose in the local ENU frame at ``origin``, twist in body axes."""
    from scipy.spatial.transform import Rotation

    from hyper_nav_gnss import earth
    from hyper_nav_workbench.core import bag
    from hyper_nav_sim.core.trajectory_file import C_n_e
    T = bag.typestore().types
    tr = traj.truth(t_s)
    lat0, lon0 = np.radians(origin["lat_deg"]), np.radians(origin["lon_deg"])
    C0 = C_n_e(np.array([lat0]), np.array([lon0]))[0]
    r0 = earth.geodetic_to_ecef(lat0, lon0, origin["alt_m"])
    p = (earth.geodetic_to_ecef(tr.lat_rad, tr.lon_rad, tr.alt_m) - r0) @ C0
    C_loc = np.einsum("ji,kjl,klm->kim", C0, C_n_e(tr.lat_rad, tr.lon_rad), tr.C_b_n)
    q = Rotation.from_matrix(C_loc).as_quat()
    v_b = np.einsum("kji,kj->ki", tr.C_b_n, tr.vel_enu_mps)
    typ = "nav_msgs/msg/Odometry"
    with bag.BagWriter(path) as w:
        for i, t in enumerate(t_s):
            ns = int(round(t * 1e9))
            stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            msg = T[typ](
                header=T["std_msgs/msg/Header"](stamp=stamp, frame_id="odom"), child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](
                    pose=T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](*map(float, p[i])),
                                                     orientation=T["geometry_msgs/msg/Quaternion"](*map(float, q[i]))),
                    covariance=np.zeros(36)),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=T["geometry_msgs/msg/Twist"](linear=T["geometry_msgs/msg/Vector3"](*map(float, v_b[i])),
                                                       angular=T["geometry_msgs/msg/Vector3"](0.0, 0.0, 0.0)),
                    covariance=np.zeros(36)))
            w.write("/odom", typ, ns, bag.serialize(msg, typ))


def test_odometry_bag_flies_the_same(flight, tmp_path):
    sc, _ = flight
    origin = {"lat_deg": 30.0, "lon_deg": 120.0, "alt_m": 0.0}
    _odometry_bag(tmp_path / "odom_bag", sc.trajectory(), np.arange(0.0, 60.0 + 1e-9, 0.1), origin)
    ft = FileTrajectory.from_config({"bag": str(tmp_path / "odom_bag"), "topic": "/odom", "origin": origin})
    t = np.arange(1, 3001) / 50.0
    a, b = sc.trajectory().imu_increments(t, 0.02), ft.imu_increments(t, 0.02)
    assert np.abs(a[0] - b[0]).max() < 3e-5
    assert np.abs(a[1] - b[1]).max() < 9e-4
    with pytest.raises(ValueError, match="trajectory_file.origin"):
        FileTrajectory.from_config({"bag": str(tmp_path / "odom_bag"), "topic": "/odom"})
