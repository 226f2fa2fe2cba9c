"""Alpha-beta extrapolation of the vehicle position (core.alpha_beta)."""
import numpy as np
import pytest

from hyper_nav_aiding.virtual_gnss.core.alpha_beta import AlphaBetaTracker, kalata_gains


def test_kalata_gains():
    """Tracking index 1: alpha 0.75, beta 0.5 (Kalata 1984, closed form);
    small index: alpha ~ sqrt(2 lambda), beta ~ lambda."""
    assert kalata_gains(1.0) == pytest.approx((0.75, 0.5))
    a, b = kalata_gains(1e-4)
    assert a == pytest.approx(np.sqrt(2e-4), rel=0.02) and b == pytest.approx(1e-4, rel=0.02)


def test_tracks_a_constant_velocity_and_extrapolates_it():
    """Noisy fixes (5 m) of a straight 2 km/s path at 1 Hz: after 60 fixes the
    velocity is within 1 m/s and the extrapolation 100 s ahead within 150 m
    (measured 0.16 m/s, 16 m) and inside its own stated uncertainty, which grows
    with the gap."""
    rng = np.random.default_rng(0)
    v = np.array([1500.0, -1200.0, 600.0])
    tr = AlphaBetaTracker(accel_sigma_mps2=0.05, fix_sigma_m=5.0, period_s=1.0)
    for t in range(60):
        tr.update(float(t), v * t + 5.0 * rng.standard_normal(3), v if t == 0 else None)
    r, v_est = tr.predict(159.0)
    err = np.abs(r - v * 159.0).max()
    s = tr.position_sigma_m(159.0)
    print(f"\nvelocity error {np.abs(v_est - v).max():.2f} m/s, extrapolation error after 100 s {err:.1f} m, "
          f"stated sigma {s:.1f} m")
    assert np.abs(v_est - v).max() < 1.0 and err < 150.0 and err < 3.0 * s
    assert tr.position_sigma_m(59.0) < tr.position_sigma_m(100.0) < s
    with pytest.raises(ValueError, match="no fix yet"):
        AlphaBetaTracker(1.0, 1.0, 1.0).predict(0.0)
