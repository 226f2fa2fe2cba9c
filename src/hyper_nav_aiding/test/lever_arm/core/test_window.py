"""Window buffer (core.lever_arm.window): cuts the latest window from a
stored fused state, keeps GNSS in time order, trims old data."""
import numpy as np

from hyper_nav_aiding.lever_arm.core.window import WindowBuffer
from hyper_nav_filter.core.measurements import GnssVelocity
from hyper_nav_filter.core.nav_state import NavState


def state(t):
    return NavState(t, 0.5, 2.0, 30000.0, np.array([0.0, 1700.0, 0.0]), np.eye(3))


def test_window_from_the_latest_state_before_its_start():
    buf = WindowBuffer(20.0)
    for k in range(1, 1501):                    # 30 s at 50 Hz
        t = k * 0.02
        buf.add_imu(t, np.full(3, 1e-4), np.full(3, 0.1))
        if k % 5 == 0:
            buf.add_gnss(GnssVelocity(t, np.zeros(3), np.eye(3)))
        if k % 50 == 0:
            buf.add_state(state(t), np.eye(24))
    w = buf.window(10.0)
    assert w.t0_s == 20.0 and w.t_end_s == 30.0
    assert len(w.imu_t_s) == 500 and w.imu_t_s[0] > w.t0_s
    assert len(w.gnss) == 100 and all(w.t0_s < m.t_s <= w.t_end_s for m in w.gnss)
    w.check()
    assert buf.window(10.0, t_end_s=25.5).t0_s == 15.0
    assert buf.window(25.0) is None              # older than the 20 s kept
    assert not buf.add_imu(29.0, np.zeros(3), np.zeros(3))     # out of order: ignored


def test_late_gnss_goes_to_its_place():
    buf = WindowBuffer(10.0)
    buf.add_imu(1.0, np.zeros(3), np.zeros(3))
    for t in (0.3, 0.5, 0.4):
        buf.add_gnss(GnssVelocity(t, np.zeros(3), np.eye(3)))
    assert [m.t_s for m in buf._gnss] == [0.3, 0.4, 0.5]


def test_window_carries_the_structures_load_when_every_sample_has_it():
    """The load (ImuSample.load_f_b_mps2, issue 24) rides with the IMU samples
    into the window and its replay samples; a window with a sample without
    it carries none (the filter then takes the measured force)."""
    buf = WindowBuffer(20.0)
    for k in range(1, 301):
        t = k * 0.02
        buf.add_imu(t, np.full(3, 1e-4), np.full(3, 0.1), None if k == 60 else np.array([0.0, 0.0, 9.0 + k]))
        if k % 5 == 0:
            buf.add_gnss(GnssVelocity(t, np.zeros(3), np.eye(3)))
        if k % 50 == 0:
            buf.add_state(state(t), np.eye(24))
    w = buf.window(3.0)
    assert w.t0_s == 3.0 and w.imu_load_f_b_mps2.shape == (150, 3)
    np.testing.assert_array_equal(w.imu_load_f_b_mps2[:, 2], 9.0 + np.arange(151, 301))
    s = w.imu_sample(0, w.t0_s)
    assert abs(s.dt_s - 0.02) < 1e-12 and s.load_f_b_mps2[2] == 160.0
    w_gap = buf.window(4.5)                                    # from the state at 1.0 s: holds t = 1.2 s
    assert w_gap.t0_s == 1.0 and w_gap.imu_load_f_b_mps2 is None
