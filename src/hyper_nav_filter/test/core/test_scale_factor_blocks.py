"""Scale-factor state blocks ``sg`` / ``sa`` (core.blocks.imu_errors): the
exact compensation omega = (omega_meas - b) / (1 + s), by the NavState and
by the filter from its block values, and their priors. Their error
dynamics in both frames are in test_frames_and_blocks."""
import numpy as np
import pytest

from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_filter.core.state_layout import INS_21_SF as LAY

SG = np.array([800e-6, -600e-6, 1000e-6])
SA = np.array([-700e-6, 900e-6, 500e-6])


@pytest.mark.parametrize("frame", ["ENU", "LCI"])
def test_compensation_divides_out_the_scale_factor(frame):
    nav = NavState(0.0, 0.5, 1.0, 100.0, np.zeros(3), np.eye(3), np.full(3, 1e-5), np.full(3, 1e-3),
                   {"sg": SG.copy(), "sa": SA.copy()})
    w, f, dt = np.array([0.1, -0.2, 0.3]), np.array([20.0, -3.0, 9.0]), 0.01
    meas = (((1 + SG) * w + 1e-5) * dt, ((1 + SA) * f + 1e-3) * dt)
    for dth, dv in (nav.compensate(*meas, dt),
                    ErrorStateKF(FilterConfig(state_blocks=LAY.names, mechanization_frame=frame), nav).corrected(
                        *meas, dt)):
        np.testing.assert_allclose(dth, w * dt, rtol=1e-12)
        np.testing.assert_allclose(dv, f * dt, rtol=1e-12)


def test_prior_and_injection_of_the_scale_factors():
    cfg = FilterConfig(state_blocks=LAY.names)
    assert cfg.initial_covariance()[LAY.sl("sg"), LAY.sl("sg")][0, 0] == pytest.approx((100e-6) ** 2)
    kf = ErrorStateKF(cfg, NavState(0.0, 0.5, 1.0, 100.0, np.zeros(3), np.eye(3), extra={"sg": SG, "sa": SA}))
    dx = np.zeros(LAY.dim)
    dx[LAY.sl("sg")], dx[LAY.sl("sa")] = SG, SA
    kf.inject(dx)
    np.testing.assert_allclose(kf.state.extra["sg"], 0.0, atol=1e-18)
    np.testing.assert_allclose(kf.state.extra["sa"], 0.0, atol=1e-18)
