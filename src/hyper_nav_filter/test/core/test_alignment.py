"""Initial alignment (core/alignment.py) on simulated static and moving starts,
MEMS and navigation grade: the attitude error against the simulated truth
stays inside 3 x the predicted sigma on every seeded draw, and the predicted
sigma is not inflated (normalised RMS over draws and axes above 0.1)."""
import math

import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_filter.core.alignment import AlignmentError, ImuGrade, align, level
from hyper_nav_filter.core.attitude import attitude_error_n_rad, euler_to_C_b_n, rotvec_to_C

LAT, ALT = math.radians(40.1), 1600.0
DEG = math.pi / 180
MEMS = ImuGrade(accel_bias_sigma_mps2=0.05, gyro_bias_sigma_radps=0.2 * DEG,
                gyro_arw_radps_per_sqrt_hz=0.0038 * DEG, accel_vrw_mps2_per_sqrt_hz=70e-6 * earth.G0_MPS2)
NAV = ImuGrade(accel_bias_sigma_mps2=25e-6 * earth.G0_MPS2, gyro_bias_sigma_radps=0.005 * DEG / 3600,
               gyro_arw_radps_per_sqrt_hz=0.002 * DEG / 60, accel_vrw_mps2_per_sqrt_hz=10e-6 * earth.G0_MPS2)
SEEDS = range(6)


def _simulate(rng, grade, C0, duration_s, rate_hz=100.0, yaw_rate_radps=0.0, turn=(0.0, 0.0), speed_mps=0.0,
              start_moving_s=math.inf, gnss_rate_hz=4.0, vel_sigma_mps=0.05):
    """IMU rates (FLU) of a body that sits (or moves at constant velocity along
    its x axis from ``start_moving_s``), turning about its z axis at
    ``yaw_rate_radps`` during ``turn`` = (t0, t1); + GNSS ENU velocities."""
    dt = 1.0 / rate_hz
    t = np.arange(1, int(duration_s * rate_hz) + 1) * dt
    f_n = -earth.gravity_n(LAT, ALT)
    w_ie = earth.omega_ie_n(LAT)
    ba = rng.normal(0, grade.accel_bias_sigma_mps2, 3)
    bg = rng.normal(0, grade.gyro_bias_sigma_radps, 3)
    C, Cs = C0.copy(), []
    w = np.empty((len(t), 3))
    f = np.empty((len(t), 3))
    for k, tk in enumerate(t):
        r = yaw_rate_radps if turn[0] < tk <= turn[1] else 0.0
        C = C @ rotvec_to_C(np.array([0.0, 0.0, r * dt]))
        Cs.append(C)
        w[k] = C.T @ w_ie + (0.0, 0.0, r)
        f[k] = C.T @ f_n
    w += bg + rng.normal(0, grade.gyro_arw_radps_per_sqrt_hz / math.sqrt(dt), w.shape)
    f += ba + rng.normal(0, grade.accel_vrw_mps2_per_sqrt_hz / math.sqrt(dt), f.shape)
    tg = np.arange(0.0, duration_s, 1.0 / gnss_rate_hz)
    vel = np.zeros((len(tg), 3))
    for j, tj in enumerate(tg):
        if tj >= start_moving_s:
            x = Cs[max(0, int(np.searchsorted(t, tj, side="right")) - 1)][:, 0]
            vel[j, :2] = speed_mps * x[:2] / np.linalg.norm(x[:2])
    vel += rng.normal(0, vel_sigma_mps, vel.shape)
    return t, w, f, tg, vel, np.array(Cs)


def _check(results, expect_method, max_sigma_deg):
    z = []
    for a, C_true in results:
        assert a.method == expect_method
        phi = attitude_error_n_rad(a.C_b_n, C_true)
        s = a.att_sigma_enu_rad
        assert np.all(np.abs(phi) < 3 * s), (np.degrees(phi), np.degrees(s))
        assert np.all(np.degrees(s) < max_sigma_deg), np.degrees(s)
        z.extend(phi / s)
    nrms = float(np.sqrt(np.mean(np.square(z))))
    assert 0.1 < nrms < 1.5, nrms


def _truth_at(a, t, Cs):
    return Cs[int(np.searchsorted(t, a.t_s - 1e-9))]


def test_level_matches_euler_convention():
    C = euler_to_C_b_n(0.3, -0.2, 1.0)
    roll, pitch = level(C.T @ np.array([0, 0, 9.8]))
    assert roll == pytest.approx(0.3, abs=1e-12) and pitch == pytest.approx(-0.2, abs=1e-12)


def test_navigation_grade_static_gyrocompasses():
    out = []
    for seed in SEEDS:
        rng = np.random.default_rng(seed)
        C0 = euler_to_C_b_n(*rng.uniform(-0.1, 0.1, 2), rng.uniform(0, 2 * math.pi))
        t, w, f, tg, vel, Cs = _simulate(rng, NAV, C0, 60.0)
        a = align(t, w, f, LAT, ALT, NAV, tg, vel, 0.05, window_s=60.0)
        out.append((a, _truth_at(a, t, Cs)))
    _check(out, "gyrocompass", max_sigma_deg=0.2)          # ~0.03 deg heading, ~0.001 deg tilt


def test_navigation_grade_moving_start_takes_course():
    out = []
    for seed in SEEDS:
        rng = np.random.default_rng(100 + seed)
        C0 = euler_to_C_b_n(*rng.uniform(-0.05, 0.05, 2), rng.uniform(0, 2 * math.pi))
        t, w, f, tg, vel, Cs = _simulate(rng, NAV, C0, 12.0, speed_mps=10.0, start_moving_s=0.0)
        a = align(t, w, f, LAT, ALT, NAV, tg, vel, 0.05, window_s=10.0)
        out.append((a, _truth_at(a, t, Cs)))
    _check(out, "gnss_velocity", max_sigma_deg=1.0)        # course sigma 0.05/10 rad = 0.3 deg


def test_mems_static_start_levels_then_takes_course_after_a_turn():
    out = []
    for seed in SEEDS:
        rng = np.random.default_rng(200 + seed)
        C0 = euler_to_C_b_n(*rng.uniform(-0.2, 0.2, 2), rng.uniform(0, 2 * math.pi))
        t, w, f, tg, vel, Cs = _simulate(rng, MEMS, C0, 14.0, yaw_rate_radps=0.5, turn=(10.0, 12.0),
                                         speed_mps=1.5, start_moving_s=12.5)
        a = align(t, w, f, LAT, ALT, MEMS, tg, vel, 0.05, window_s=10.0)
        assert a.static and a.info["carried_s"] > 2.0
        out.append((a, _truth_at(a, t, Cs)))
    _check(out, "gnss_velocity", max_sigma_deg=5.0)        # tilt: 5 mg bias -> 0.3 deg; course 0.05/1.5 rad


def test_mems_moving_start():
    out = []
    for seed in SEEDS:
        rng = np.random.default_rng(300 + seed)
        C0 = euler_to_C_b_n(*rng.uniform(-0.2, 0.2, 2), rng.uniform(0, 2 * math.pi))
        t, w, f, tg, vel, Cs = _simulate(rng, MEMS, C0, 4.0, speed_mps=1.5, start_moving_s=0.0)
        a = align(t, w, f, LAT, ALT, MEMS, tg, vel, 0.05, window_s=2.0)
        assert not a.static
        out.append((a, _truth_at(a, t, Cs)))
    _check(out, "gnss_velocity", max_sigma_deg=5.0)


def test_mems_without_gnss_velocity_is_refused():
    rng = np.random.default_rng(1)
    t, w, f, *_ = _simulate(rng, MEMS, np.eye(3), 5.0)
    with pytest.raises(AlignmentError, match="cannot gyrocompass"):
        align(t, w, f, LAT, ALT, MEMS, window_s=5.0)


def test_not_gravity_is_refused():
    rng = np.random.default_rng(1)
    t, w, f, *_ = _simulate(rng, MEMS, np.eye(3), 5.0)
    with pytest.raises(AlignmentError, match="not gravity"):
        align(t, w, f / earth.G0_MPS2, LAT, ALT, MEMS, window_s=5.0)
