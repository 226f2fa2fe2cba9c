"""Early-warning radar (seed 002 section 3.2): noise statistics."""
import numpy as np
import pytest

from hyper_nav_sim.core.radar import EarlyWarningRadar
from hyper_nav_sim.core.scenario import load_scenario


@pytest.fixture(scope="module")
def traj():
    return load_scenario("default").trajectory()


def test_noise_statistics(traj):
    radar = EarlyWarningRadar(rate_hz=20.0)
    z = radar.measure_flight(traj, np.random.default_rng(7))
    tr = traj.truth(z.t_s)
    assert len(z.t_s) == 6001 and z.t_s[-1] == pytest.approx(300.0)
    err = np.stack([z.alt_m - tr.alt_m, np.angle(np.exp(1j * (z.lon_rad - tr.lon_rad))),
                    z.lat_rad - tr.lat_rad], axis=-1)
    n = len(err)
    assert np.all(np.abs(err.mean(axis=0)) < 4 * np.array([2000.0, 0.01, 0.01]) / np.sqrt(n))
    np.testing.assert_allclose(err.std(axis=0), [2000.0, 0.01, 0.01], rtol=0.05)
    C = np.corrcoef(err.T)
    assert np.max(np.abs(C - np.eye(3))) < 0.05
    # white: lag-1 autocorrelation ~ 0
    for k in range(3):
        e = err[:, k] - err[:, k].mean()
        assert abs(np.dot(e[1:], e[:-1]) / np.dot(e, e)) < 0.05
    assert z.as_array().shape == (n, 3)
    np.testing.assert_allclose(np.diag(radar.covariance), [2000.0**2, 1e-4, 1e-4])


def test_seeded_and_reproducible(traj):
    radar = EarlyWarningRadar(rate_hz=1.0)
    a = radar.measure_flight(traj, np.random.default_rng(3))
    b = radar.measure_flight(traj, np.random.default_rng(3))
    c = radar.measure_flight(traj, np.random.default_rng(4))
    np.testing.assert_array_equal(a.as_array(), b.as_array())
    assert not np.allclose(a.as_array(), c.as_array())


def test_bad_rate():
    with pytest.raises(ValueError, match="rate_hz"):
        EarlyWarningRadar(rate_hz=0.0)
