"""Stamps on the GPST or Unix scale (~1e9 s, where 1 ns is below a float's
resolution): a measurement that reaches the engine before its epoch's IMU
sample is applied at that epoch, as at small stamps (it was never applied:
t + 1e-9 == t at 1.7e9 s)."""
import numpy as np
import pytest

from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.measurements import GnssVelocity
from hyper_nav_filter.core.nav_state import NavState


@pytest.mark.parametrize("t0", [0.0, 456300.0, 1684035200.25])
@pytest.mark.parametrize("before_imu", [True, False])
def test_measurements_at_imu_epochs_are_applied_at_any_stamp_scale(t0, before_imu):
    eng = FusionEngine(FilterConfig(), NavState(t0, 0.5, 2.0, 100.0, np.zeros(3), np.eye(3)))
    for k in range(1, 200):
        t = t0 + k * 0.02
        meas = GnssVelocity(t, np.zeros(3), np.eye(3) * 0.01) if k % 5 == 0 else None
        if meas is not None and before_imu:
            eng.add_measurement(meas)
        eng.add_imu(t, [0.0, 0.0, 0.0], [0.0, 0.0, 9.8 * 0.02])
        if meas is not None and not before_imu:
            eng.add_measurement(meas)
        eng.release()
    acc, gated, _ = eng.kf.stats["gnss_vel"]
    assert (acc, gated) == (39, 0)
