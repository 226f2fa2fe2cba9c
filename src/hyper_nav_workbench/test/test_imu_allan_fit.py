"""imu_allan_fit on a static recording the simulator writes (a known IMU:
ARW, VRW and bias instability): the printed scenario block gives them back
(white noise within 5 %, bias instability within 25 %: 1000 s leaves few
clusters at the flicker floor), in deg/s and g as a user's file has them;
unreadable rows are counted, not silently used."""
import io
import contextlib

import numpy as np
import yaml

from hyper_nav_workbench import imu_allan_fit
from hyper_nav_sim.core.imu_model import ImuErrors, corrupt_increments


def test_fit_gives_the_recordings_figures_back(tmp_path):
    cfg = {"gyro_arw_deg_per_sqrt_hr": 0.3, "accel_vrw_ug_per_sqrt_hz": 80.0,
           "gyro_bias_instability_deg_per_hr": 20.0, "accel_bias_instability_ug": 200.0,
           "bias_instability_band_s": [0.1, 1.0e4]}
    err = ImuErrors.from_config(cfg)
    rate, T = 100.0, 1000.0
    n, dt = int(rate * T), 1.0 / rate
    dth, dv = corrupt_increments(np.zeros((n, 3)), np.zeros((n, 3)), dt, err, np.random.default_rng(7))
    t = np.arange(1, n + 1) * dt
    path = tmp_path / "static.csv"
    with open(path, "w") as fh:
        fh.write("time,wx,wy,wz,fx,fy,fz\n")
        for i in range(n):
            w = np.rad2deg(dth[i] / dt)
            f = dv[i] / dt / 9.80665 + np.array([0.0, 0.0, 1.0])
            fh.write(f"{t[i]:.4f},{w[0]:.9e},{w[1]:.9e},{w[2]:.9e},{f[0]:.9e},{f[1]:.9e},{f[2]:.9e}\n")
        fh.write("1000.5,nan,0,0,0,0,1\n")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = imu_allan_fit.main([str(path), "--gyro-unit", "deg/s", "--accel-unit", "g",
                                 "--columns", "t=time,gx=wx,gy=wy,gz=wz,ax=fx,ay=fy,az=fz"])
    assert rc == 0
    out = buf.getvalue()
    assert "1 rows refused" in out
    block = yaml.safe_load(out)["imu"]
    assert abs(block["gyro_arw_deg_per_sqrt_hr"] / 0.3 - 1) < 0.05
    assert abs(block["accel_vrw_ug_per_sqrt_hz"] / 80.0 - 1) < 0.05
    assert abs(block["gyro_bias_instability_deg_per_hr"] / 20.0 - 1) < 0.25
    assert abs(block["accel_bias_instability_ug"] / 200.0 - 1) < 0.25
    assert block["rate_hz"] == 100.0
