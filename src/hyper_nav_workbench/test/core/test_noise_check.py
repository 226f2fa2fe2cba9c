"""The IMU's measured noise against the configured densities
(core/noise_check.py): a synthetic standing IMU with known white densities
and strong engine vibration (band 20-40 Hz, its raw scatter many times the
white noise): the Allan reading finds the white density, the raw scatter
does not; a data sheet 10x quieter is flagged with the suggestion, and
import_data --noise from-data adopts it."""
import math

import numpy as np
import pytest
import yaml

from hyper_nav_gnss import earth
from hyper_nav_filter.core import units
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_workbench.core import noise_check

RATE_HZ = 200.0
ARW_DEG_PER_SQRT_HR = np.array([0.3, 0.5, 0.2])
VRW_UG_PER_SQRT_HZ = np.array([150.0, 200.0, 300.0])
LAT = math.radians(45.0)


def vibration(rng, n, amp):
    """Band-limited (20-40 Hz) random vibration of standard deviation ``amp`` per axis."""
    spec = np.fft.rfft(rng.normal(size=(n, 3)), axis=0)
    f = np.fft.rfftfreq(n, 1.0 / RATE_HZ)
    spec[(f < 20.0) | (f > 40.0)] = 0.0
    x = np.fft.irfft(spec, n, axis=0)
    return x / x.std(axis=0) * amp


def standing_imu(duration_s=60.0, seed=5):
    rng = np.random.default_rng(seed)
    n = int(duration_s * RATE_HZ)
    dt = 1.0 / RATE_HZ
    t = np.arange(n) * dt
    ng = units.deg_per_sqrt_hr(ARW_DEG_PER_SQRT_HR)           # rad/sqrt(s): white rate sigma = N / sqrt(dt)
    na = units.ug_per_sqrt_hz(VRW_UG_PER_SQRT_HZ)
    w = earth.omega_ie_n(LAT) + rng.normal(size=(n, 3)) * ng / math.sqrt(dt) + vibration(rng, n, math.radians(1.0))
    f = -earth.gravity_n(LAT, 0.0) + rng.normal(size=(n, 3)) * na / math.sqrt(dt) + vibration(rng, n, 0.2)
    return t, w, f


def config(factor):
    return FilterConfig.from_dict({"gyro_arw_deg_per_sqrt_hr": (ARW_DEG_PER_SQRT_HR * factor).tolist(),
                                   "accel_vrw_ug_per_sqrt_hz": (VRW_UG_PER_SQRT_HZ * factor).tolist()})


def test_the_allan_reading_finds_the_white_density_under_vibration():
    t, w, f = standing_imu()
    chk = noise_check.check(t, w, f, config(0.1), [(0.0, 60.0)])
    assert chk.method == "allan"
    # vibration of 1 deg/s and 0.2 m/s^2 (20 mg) per axis: the raw scatter reads 4-20x the white density
    assert np.all(chk.gyro_raw > 4 * ARW_DEG_PER_SQRT_HR) and np.all(chk.accel_raw > 4 * VRW_UG_PER_SQRT_HZ)
    # measured: within 25 % of the simulated densities (60 s of data: the Allan points up to 6 s hold 10-600
    # clusters; measured 0.36/0.46/0.24 against 0.3/0.5/0.2 deg/sqrt(h))
    np.testing.assert_allclose(chk.gyro_measured, ARW_DEG_PER_SQRT_HR, rtol=0.25)
    np.testing.assert_allclose(chk.accel_measured, VRW_UG_PER_SQRT_HZ, rtol=0.25)
    assert chk.optimistic and "OPTIMISTIC" in chk.describe()
    np.testing.assert_allclose(chk.suggested()["gyro_arw_deg_per_sqrt_hr"], chk.gyro_measured)
    honest = noise_check.check(t, w, f, config(1.0), [(0.0, 60.0)])
    assert not honest.optimistic
    short = noise_check.check(t, w, f, config(1.0), [(0.0, 5.0)])
    assert short.method == "raw" and "upper bound" in short.describe()


def test_static_intervals_from_the_alignment_window_and_gnss_standstill():
    t = np.arange(0.0, 100.0, 0.01)
    gt = np.arange(0.0, 100.0, 0.5)
    v = np.zeros((len(gt), 3))
    v[(gt > 8.0) & (gt < 40.0), 1] = 5.0                      # drives from 8 to 40 s, stops, drives from 70 s
    v[gt > 70.0, 1] = 5.0
    iv = noise_check.static_intervals(t, 5.0, gt, v)
    assert iv == [(0.0, 8.0), (40.0, 70.0)]
    assert noise_check.static_intervals(t, 5.0) == [(0.0, 5.0)]


def test_import_reports_the_check_and_from_data_adopts_it(tmp_path, capsys):
    from hyper_nav_workbench import import_data, replay_filter
    t, w, f = standing_imu(60.0)
    np.savetxt(tmp_path / "imu.txt", np.column_stack([t + 1000.0, w, f]), fmt="%.12g")
    gt = np.arange(1000.0, 1060.0, 0.25)
    np.savetxt(tmp_path / "gnss.txt", np.column_stack([gt, np.full(len(gt), 45.0), np.full(len(gt), 7.0),
                                                       np.zeros(len(gt)), np.full((len(gt), 3), 0.02),
                                                       np.zeros((len(gt), 3)), np.full((len(gt), 3), 0.02)]),
               fmt="%.12g")
    doc = {"imu": {"file": "imu.txt", "time": {"column": 0}, "kind": "rates", "gyro": {"columns": [1, 2, 3]},
                   "accel": {"columns": [4, 5, 6]}},
           "gnss": {"file": "gnss.txt", "time": {"column": 0}, "lat": {"column": 1}, "lon": {"column": 2},
                    "alt": {"column": 3}, "sigma": {"columns": [4, 5, 6]}, "velocity": {"columns": [7, 8, 9]},
                    "vel_sigma": {"columns": [10, 11, 12]}},
           "filter": {"config": {"gyro_arw_deg_per_sqrt_hr": (ARW_DEG_PER_SQRT_HR / 10).tolist(),
                                 "accel_vrw_ug_per_sqrt_hz": (VRW_UG_PER_SQRT_HZ / 10).tolist(),
                                 "gyro_bias_sigma_deg_per_hr": [10.0] * 3},
                      "initial_state": {"lat_deg": 45.0, "lon_deg": 7.0, "alt_m": 0.0,
                                        "roll_pitch_heading_deg": [0.0, 0.0, 0.0]}}}
    (tmp_path / "import.yaml").write_text(yaml.safe_dump(doc))
    assert import_data.main([str(tmp_path / "import.yaml"), "--out", str(tmp_path / "check")]) == 0
    text = capsys.readouterr().out
    assert "IMU noise on 1 static interval(s)" in text and "OPTIMISTIC" in text
    kept = yaml.safe_load((tmp_path / "check" / "filter.yaml").read_text())["filter"]["config"]
    assert kept["gyro_arw_deg_per_sqrt_hr"] == pytest.approx((ARW_DEG_PER_SQRT_HR / 10).tolist())
    assert import_data.main([str(tmp_path / "import.yaml"), "--out", str(tmp_path / "adopt"),
                             "--noise", "from-data"]) == 0
    capsys.readouterr()
    adopted = yaml.safe_load((tmp_path / "adopt" / "filter.yaml").read_text())["filter"]["config"]
    np.testing.assert_allclose(adopted["gyro_arw_deg_per_sqrt_hr"], ARW_DEG_PER_SQRT_HR, rtol=0.3)
    np.testing.assert_allclose(adopted["accel_vrw_ug_per_sqrt_hz"], VRW_UG_PER_SQRT_HZ, rtol=0.3)
    replay_filter.main([str(tmp_path / "check")])
    text = capsys.readouterr().out
    assert "IMU noise measured at import (allan)" in text and "warning: imu noise: measured densities above" in text
