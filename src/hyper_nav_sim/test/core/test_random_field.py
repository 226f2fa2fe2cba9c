"""Smooth Gaussian random fields of the simulated world (core.random_field)."""
import numpy as np

from hyper_nav_sim.core.random_field import GaussianField


def test_unit_variance_and_squared_exponential_covariance():
    """Over 400 realisations: variance 1 and correlation exp(-d^2 / 2 L^2) at
    d = 0.5, 1, 2 L (0.88, 0.61, 0.14) within 0.05; per-field length scales."""
    x0 = np.zeros((1, 2))
    lags = np.array([0.5, 1.0, 2.0])
    vals = []
    for seed in range(400):
        f = GaussianField([[3.0, 1.0], [30.0, 10.0]], np.random.default_rng(seed), n_fields=2)
        pts = np.vstack([x0, np.stack([lags * 3.0, np.zeros(3)], -1)])       # along the first axis
        vals.append(f(pts))
    v = np.array(vals)                                                      # (400, 4 points, 2 fields)
    assert abs(v[:, 0, 0].var() - 1.0) < 0.15
    corr = [np.corrcoef(v[:, 0, 0], v[:, k + 1, 0])[0, 1] for k in range(3)]
    np.testing.assert_allclose(corr, np.exp(-lags ** 2 / 2), atol=0.05)
    # field 2 has 10x the length scale: nearly fully correlated at the same points
    assert np.corrcoef(v[:, 0, 1], v[:, 3, 1])[0, 1] > 0.97


def test_gradient_is_the_derivative():
    f = GaussianField([2.0, 5.0, 1.0], np.random.default_rng(3), n_fields=3)
    x = np.array([[0.3, -1.2, 4.0], [2.0, 0.0, -3.0]])
    val, grad = f.value_and_gradient(x)
    np.testing.assert_allclose(val, f(x))
    h = 1e-6
    for d in range(3):
        dx = np.zeros(3)
        dx[d] = h
        np.testing.assert_allclose((f(x + dx) - f(x - dx)) / (2 * h), grad[..., d], atol=1e-7)
