"""The attitude block's rate-proportional gyro error (core.blocks.nav,
``gyro_rate_error_pct``): each predict adds 2 sigma^2 |dtheta|^2 tau / dt
to every attitude variance, nothing when the body does not turn, and the
compiled and reference predicts agree."""
import numpy as np
import pytest

from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.nav_state import ImuSample, NavState

G_B = np.array([0.0, 0.0, 9.80])


def _P_after(cfg, dth, fast=True, dt=1.0 / 150.0):
    s = NavState(0.0, 0.7, -1.8, 1600.0, np.array([1.0, 0.5, 0.0]), np.eye(3))
    kf = ErrorStateKF(cfg, s, cfg.initial_covariance(), fast=fast)
    kf.predict(ImuSample(dt, dt, np.asarray(dth, float), G_B * dt))
    return kf.P, cfg.layout.sl("att")


@pytest.mark.parametrize("fast", [True, False])
def test_turning_adds_the_rate_proportional_variance(fast):
    dt = 1.0 / 150.0
    w = np.deg2rad(np.array([10.0, -20.0, 90.0]))                    # a walker's turn, rad/s
    base = FilterConfig.from_dict({"gyro_rate_error_pct": 0.0})
    on = FilterConfig.from_dict({"gyro_rate_error_pct": 0.36, "gyro_rate_error_tau_s": 1.0})
    P0, a = _P_after(base, w * dt, fast, dt)
    P1, _ = _P_after(on, w * dt, fast, dt)
    expected = 2.0 * 0.0036 ** 2 * float(w @ w) * 1.0 * dt           # rad^2 per axis
    np.testing.assert_allclose(np.diag(P1 - P0)[a], expected, rtol=1e-9)
    d = P1 - P0
    d[a, a] -= expected * np.eye(3)
    assert np.abs(d).max() < 1e-18                                   # nothing else changes in this step


def test_no_rotation_no_extra_noise():
    P0, _ = _P_after(FilterConfig.from_dict({"gyro_rate_error_pct": 0.0}), np.zeros(3))
    P1, _ = _P_after(FilterConfig.from_dict({"gyro_rate_error_pct": 0.36}), np.zeros(3))
    assert np.array_equal(P0, P1)
