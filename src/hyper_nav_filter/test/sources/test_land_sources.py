"""Land-vehicle constraints (core.land_vehicle, sources/land.py): the ZUPT
holds a standing vehicle's velocity and position where the IMU alone
drifts; the standstill test refuses a moving IMU; the NHC's Jacobian is the
derivative of its residual; neither is in a default table."""
from types import SimpleNamespace as NS

import dataclasses
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hyper_nav_gnss import earth
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.land_vehicle import NonHolonomic, StandstillDetector
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_filter.sources import DEFAULT_TABLE
from hyper_nav_filter.sources.router import SourceRouter

LAT, LON, ALT = math.radians(45.0), math.radians(7.0), 300.0
RATE_HZ = 100.0
ACCEL_BIAS_MPS2 = np.array([0.01, -0.008, 0.0])          # 1 mg-class, not in the filter's initial state


def header(t):
    return NS(stamp=NS(sec=int(t), nanosec=int(round((t - int(t)) * 1e9))), frame_id="imu")


def imu_msg(t, w, f):
    return NS(header=header(t), angular_velocity=NS(x=w[0], y=w[1], z=w[2]),
              linear_acceleration=NS(x=f[0], y=f[1], z=f[2]))


def standing_imu(duration_s, rng):
    """A level IMU standing still (body FLU = ENU): Earth rate and -gravity plus white noise and an accel bias."""
    g = -earth.gravity_n(LAT, ALT)
    w_ie = earth.omega_ie_n(LAT)
    n = int(duration_s * RATE_HZ)
    t = (np.arange(n) + 1) / RATE_HZ
    w = w_ie + rng.normal(0.0, math.radians(0.05), (n, 3))
    f = g + ACCEL_BIAS_MPS2 + rng.normal(0.0, 0.02, (n, 3))
    return t, w, f


def run(table, t, w, f):
    cfg = FilterConfig.from_dict({"gyro_arw_deg_per_sqrt_hr": [0.3] * 3, "accel_vrw_ug_per_sqrt_hz": [300.0] * 3,
                                  "accel_bias_sigma_ug": [2000.0] * 3, "init_att_sigma_deg": [0.1, 0.1, 1.0],
                                  "init_vel_sigma_mps": [0.01] * 3, "init_pos_sigma_m": [0.1] * 3})
    eng = FusionEngine(cfg, NavState(0.0, LAT, LON, ALT, np.zeros(3), np.eye(3)))
    router = SourceRouter(eng, table)
    sols = []
    for k in range(len(t)):
        sols += router.handle_topic("imu/data_raw", imu_msg(t[k], w[k], f[k]))[1]
    sols += eng.release(final=True)
    s = sols[-1].state
    return eng, router, np.linalg.norm(s.vel_enu_mps), np.linalg.norm(
        earth.position_error_enu_m(s.lat_rad, s.lon_rad, s.alt_m, LAT, LON, ALT))


def test_zupt_holds_a_standing_vehicle_where_the_imu_alone_drifts():
    t, w, f = standing_imu(60.0, np.random.default_rng(7))
    imu_only = {"imu": {"type": "imu", "topic": "imu/data_raw"}}
    _, _, v0, p0 = run(imu_only, t, w, f)
    eng, router, v1, p1 = run({**imu_only, "zupt": {"type": "zupt", "topic": "imu/data_raw", "sigma_mps": 0.01,
                                                     "gyro_max_deg_per_s": 1.0, "accel_std_max_mps2": 0.1}},
                              t, w, f)
    acc, gated, _ = eng.kf.stats["zupt"]
    assert acc > 550 and gated == 0                           # 10 Hz over 60 s (after the first 0.5 s window)
    # the IMU alone: 1 mg over 60 s, about 0.6 m/s and 18 m; with the ZUPT: held
    assert v0 > 0.3 and p0 > 5.0, (v0, p0)
    assert v1 < 0.02 and p1 < 0.3, (v1, p1)
    assert router.diagnostics()["processed imu/data_raw (zupt)"] == acc


def test_the_standstill_test_refuses_a_moving_imu():
    det = StandstillDetector(0.5, 1.0, 0.1)
    g = np.array([0.0, 0.0, 9.81])
    assert not any(det.add(k / RATE_HZ, [0.0, 0.0, math.radians(5.0)], g) for k in range(1, 200))    # turning
    det = StandstillDetector(0.5, 1.0, 0.1)
    rng = np.random.default_rng(1)
    assert not any(det.add(k / RATE_HZ, [0.0, 0.0, 0.0], g + [0.0, 0.0, rng.normal(0, 0.5)])        # bumps
                   for k in range(1, 200))
    det = StandstillDetector(0.5, 1.0, 0.1)
    assert [det.add(k / RATE_HZ, [0.0, 0.0, 0.0], g) for k in range(1, 60)][-1]                     # still


def test_the_nhc_jacobian_is_the_derivative_of_its_residual():
    cfg = FilterConfig()
    lay = cfg.layout
    C = Rotation.from_euler("ZYX", [0.7, 0.05, -0.03]).as_matrix()
    v = C @ np.array([15.0, 0.3, -0.1])                       # mostly forward, a little sideslip
    truth = NavState(0.0, LAT, LON, ALT, v, C)
    r0, H, R = NonHolonomic(0.0, 0.01).model(truth, lay, None)
    assert r0 == pytest.approx([0.3, -0.1], abs=1e-12) and R.shape == (2, 2)
    phi, dv = np.array([1e-4, -2e-4, 3e-4]), np.array([1e-3, -2e-3, 5e-4])
    est = dataclasses.replace(truth, vel_enu_mps=v + dv, C_b_n=Rotation.from_rotvec(-phi).as_matrix() @ C)
    r1, _, _ = NonHolonomic(0.0, 0.01).model(est, lay, None)
    dx = np.zeros(lay.dim)
    dx[lay.sl("att")], dx[lay.sl("vel")] = phi, dv
    # to first order (the second-order terms, |phi| |dv| + |phi|^2 |v| ~ 2e-6, against a change of 2-4e-3)
    assert r1 - r0 == pytest.approx(H @ dx, abs=3e-6)
    assert np.abs(H @ dx).min() > 1e-3


def test_land_constraints_are_not_in_the_default_table():
    assert not any(e["type"] in ("zupt", "nhc") for e in DEFAULT_TABLE.values())


def test_nhc_holds_the_cross_track_of_a_car_driving_without_gnss():
    """A car driving due east at 10 m/s, level, 40 s without GNSS, a lateral and vertical accelerometer bias
    of 10 and 8 mg the filter does not know: the IMU alone drifts metres north and up; with the NHC
    (10 Hz, 0.1 m/s) the lateral and vertical velocity stay near zero and so do those errors."""
    rng = np.random.default_rng(11)
    v_n = np.array([10.0, 0.0, 0.0])                          # body FLU = ENU (x east, level)
    w_ie, w_en = earth.omega_ie_n(LAT), earth.omega_en_n(LAT, ALT, v_n)
    f_n = np.cross(2.0 * w_ie + w_en, v_n) - earth.gravity_n(LAT, ALT)
    n = int(40.0 * RATE_HZ)
    t = (np.arange(n) + 1) / RATE_HZ
    w = (w_ie + w_en) + rng.normal(0.0, math.radians(0.01), (n, 3))
    f = f_n + np.array([0.0, 0.1, 0.08]) + rng.normal(0.0, 0.005, (n, 3))
    cfg = FilterConfig.from_dict({"gyro_arw_deg_per_sqrt_hr": [0.1] * 3, "accel_vrw_ug_per_sqrt_hz": [100.0] * 3,
                                  "accel_bias_sigma_ug": [20000.0] * 3, "init_att_sigma_deg": [0.05, 0.05, 0.2],
                                  "init_vel_sigma_mps": [0.05] * 3, "init_pos_sigma_m": [0.1] * 3})
    _, r_n = earth.radii(LAT)
    lon_end = LON + 10.0 * t[-1] / ((r_n + ALT) * math.cos(LAT))
    err = {}
    for name, extra in (("imu", {}), ("nhc", {"nhc": {"type": "nhc", "topic": "imu/data_raw", "sigma_mps": 0.1}})):
        eng = FusionEngine(cfg, NavState(0.0, LAT, LON, ALT, v_n.copy(), np.eye(3)))
        router = SourceRouter(eng, {"imu": {"type": "imu", "topic": "imu/data_raw"}, **extra})
        for k in range(n):
            router.handle_topic("imu/data_raw", imu_msg(t[k], w[k], f[k]))
        s = eng.release(final=True)[-1].state
        err[name] = earth.position_error_enu_m(s.lat_rad, s.lon_rad, s.alt_m, LAT, lon_end, ALT)
        if name == "nhc":
            acc, gated, _ = eng.kf.stats["nhc"]
            assert acc > 390 and gated == 0
    # IMU alone: 0.5 x 0.1 m/s^2 x (40 s)^2 = 80 m north, 64 m up; with the NHC: below 2 m
    print(f"north/up error after 40 s: IMU alone {err['imu'][1]:.2f} / {err['imu'][2]:.2f} m, with the NHC "
          f"{err['nhc'][1]:.2f} / {err['nhc'][2]:.2f} m")
    assert abs(err["imu"][1]) > 50.0 and abs(err["imu"][2]) > 40.0, err
    assert abs(err["nhc"][1]) < 2.0 and abs(err["nhc"][2]) < 2.0, err
