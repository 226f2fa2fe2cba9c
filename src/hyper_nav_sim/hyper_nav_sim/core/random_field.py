"""Smooth stationary Gaussian random fields and processes for the simulated
world (ionosphere residual, meteorology, broadcast orbit/clock errors).

Random Fourier features (Rahimi & Recht, "Random features for large-scale
kernel machines", NIPS 2007): with M frequencies w_m ~ N(0, diag(1/L^2))
and phases phi_m ~ U(0, 2 pi),

    g(x) = sqrt(2 / M) sum_m cos(w_m . x + phi_m)

has zero mean, unit variance and, over the draws, the squared-exponential
covariance E[g(x) g(x')] = exp(-sum_i (x_i - x'_i)^2 / (2 L_i^2)). One
realisation is a smooth function that can be evaluated anywhere (any
position, any time, in any order) at O(M) cost, with an exact analytic
gradient: what a simulator of a continuous world needs. For a 1-D process
with correlation time tau, the RMS change over a short lag dt is
sqrt(2 (1 - exp(-dt^2 / 2 tau^2))) ~ dt / tau (unit variance).
The marginal is a sum of M cosines, Gaussian to within the central limit
(M = 256: kurtosis 3 - 3/(2M) ~ 2.994).
"""
from __future__ import annotations

import numpy as np


class GaussianField:
    """One realisation of a unit-variance Gaussian field over R^d with
    squared-exponential covariance of length scales ``length_scales`` (d,)
    (each in the unit of its coordinate). ``n_fields`` independent fields
    share one call (output (..., n_fields)); ``length_scales`` may then be
    (n_fields, d), one set per field."""

    def __init__(self, length_scales, rng: np.random.Generator, n_features: int = 256, n_fields: int = 1):
        L = np.asarray(length_scales, float)
        L = L.reshape(1, -1) if L.ndim < 2 else L
        if np.any(~np.isfinite(L)) or np.any(L <= 0.0):
            raise ValueError(f"length scales must be finite and > 0, got {L.tolist()}")
        self.dim = L.shape[1]
        self.n_fields = int(n_fields)
        if L.shape[0] not in (1, self.n_fields):
            raise ValueError(f"length scales: expected (d,) or ({self.n_fields}, d), got {L.shape}")
        self._w = rng.standard_normal((self.n_fields, n_features, self.dim)) / L[:, None, :]     # (F, M, d)
        self._phi = rng.uniform(0.0, 2.0 * np.pi, (self.n_fields, n_features))
        self._amp = np.sqrt(2.0 / n_features)

    def __call__(self, x):
        """Field values at points x (..., d) -> (..., n_fields)."""
        x = np.asarray(x, float)
        arg = np.einsum("fmd,...d->...fm", self._w, x) + self._phi
        return self._amp * np.cos(arg).sum(axis=-1)

    def value_and_gradient(self, x):
        """(values (..., F), gradients (..., F, d)) at points x (..., d)."""
        x = np.asarray(x, float)
        arg = np.einsum("fmd,...d->...fm", self._w, x) + self._phi
        val = self._amp * np.cos(arg).sum(axis=-1)
        grad = -self._amp * np.einsum("...fm,fmd->...fd", np.sin(arg), self._w)
        return val, grad
