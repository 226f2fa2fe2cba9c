"""Overlapping Allan deviation of a rate series and the IEEE Std 952 readings.

For rate samples y_k at interval dt, integrated angle x_j = dt * sum_{k<j} y_k,
the overlapping Allan variance at tau = m dt is (IEEE Std 952-1997 eq. C.12)::

    AVAR(tau) = sum_j (x_{j+2m} - 2 x_{j+m} + x_j)^2 / (2 tau^2 (N - 2m + 1))

Noise terms and their Allan signatures (two-sided PSDs):
  angle random walk N       AVAR = N^2 / tau             (slope -1/2; read at tau = 1 s)
  bias instability B        ADEV floor = 0.664 B         (flat; B = min / 0.664)
  rate random walk K        AVAR = K^2 tau / 3           (slope +1/2)

``bias_instability_from_minimum`` is the textbook reading (minimum / 0.664);
when the white noise has not died out at the minimum it reads high by
sqrt(1 + N^2 / (tau_min (0.664 B)^2)). ``fit_noise_terms`` fits
AVAR = N^2/tau + (0.664 B)^2 + K^2 tau/3 by weighted least squares and
separates the two, which is what the tests use for the 10 % checks.
numpy only (allantools is not installed in the venv).
"""
from __future__ import annotations

import numpy as np

from hyper_nav_sim.core.imu_model import FLICKER_FLOOR


def log_taus(n_samples: int, dt_s: float, per_decade: int = 10, max_fraction: float = 0.25) -> np.ndarray:
    """Cluster sizes m (integers, log-spaced, deduplicated) up to max_fraction of the record."""
    m_max = max(1, int(n_samples * max_fraction))
    m = np.unique(np.round(np.logspace(0, np.log10(m_max), int(per_decade * np.log10(m_max)) + 2)).astype(int))
    return m * dt_s


def overlapping_adev(rate, dt_s: float, taus_s=None):
    """Overlapping Allan deviation of ``rate`` (shape (N,) or (N, k): each
    column separately). Returns (taus_s, adev (len(taus),) or (len(taus), k),
    n_terms = number of overlapping differences per tau)."""
    y = np.asarray(rate, dtype=float)
    squeeze = y.ndim == 1
    if squeeze:
        y = y[:, None]
    n = y.shape[0]
    if taus_s is None:
        taus_s = log_taus(n, dt_s)
    m_all = np.unique(np.maximum(1, np.round(np.asarray(taus_s, float) / dt_s).astype(int)))
    m_all = m_all[2 * m_all <= n]
    x = np.vstack([np.zeros((1, y.shape[1])), np.cumsum(y, axis=0) * dt_s])
    out = np.empty((len(m_all), y.shape[1]))
    n_terms = np.empty(len(m_all), dtype=int)
    for i, m in enumerate(m_all):
        d = x[2 * m:] - 2.0 * x[m:-m] + x[:-2 * m]
        tau = m * dt_s
        out[i] = np.sqrt(np.mean(d**2, axis=0) / (2.0 * tau**2))
        n_terms[i] = d.shape[0]
    taus = m_all * dt_s
    return taus, (out[:, 0] if squeeze else out), n_terms


def adev_relative_sigma(taus_s, n_samples: int, dt_s: float):
    """Approximate 1-sigma relative uncertainty of an overlapping ADEV
    estimate: 1 / sqrt(2 (N/m - 1)) (number of independent clusters;
    conservative for the overlapping estimator)."""
    k = n_samples * dt_s / np.asarray(taus_s, float)
    return 1.0 / np.sqrt(2.0 * np.maximum(k - 1.0, 1.0))


def arw_from_adev(taus_s, adev, tau_max_s: float = 10.0) -> float:
    """Angle/velocity random walk N [rate * sqrt(s)]: a slope -1/2 line
    sigma = N / sqrt(tau) fitted (in log, slope fixed) to the points with
    tau <= tau_max_s, read at tau = 1 s."""
    taus_s, adev = np.asarray(taus_s, float), np.asarray(adev, float)
    sel = taus_s <= tau_max_s
    return float(np.exp(np.mean(np.log(adev[sel]) + 0.5 * np.log(taus_s[sel]))))


def bias_instability_from_minimum(taus_s, adev, arw=None, tau_max_s=None) -> float:
    """Bias instability B = min(ADEV) / 0.664 (IEEE Std 952 flicker floor).

    ``tau_max_s`` restricts the search to taus with enough clusters (about
    record / 50: the minimum of noisy long-tau points reads low); with
    ``arw`` given, its share N^2/tau at the minimum is removed first:
    B = sqrt(min^2 - N^2 / tau_min) / 0.664 (otherwise it reads high)."""
    taus_s, adev = np.asarray(taus_s, float), np.asarray(adev, float)
    sel = np.ones(taus_s.shape, bool) if tau_max_s is None else taus_s <= tau_max_s
    i = int(np.argmin(adev[sel]))
    a2 = adev[sel][i] ** 2
    if arw is not None:
        a2 = max(a2 - arw**2 / taus_s[sel][i], 0.0)
    return float(np.sqrt(a2) / FLICKER_FLOOR)


def fit_noise_terms(taus_s, adev, rel_sigma=None, tau_range_s=(0.0, np.inf), rate_random_walk=False,
                    quantization=False, bias_instability=True):
    """Weighted least squares of AVAR(tau) = [3 Q^2/tau^2 +] N^2/tau + (0.664 B)^2 [+ K^2 tau/3].
    ``rel_sigma``: relative sigma of each ADEV point (weights); returns a
    dict with N (ARW), B (bias instability), K (rate random walk, 0 when
    not fitted) and Q (the tau^-2 term, 0 when not fitted: quantization
    noise, IEEE Std 952 C.2, and vibration above 1 / tau, whose Allan
    variance falls as tau^-2 too), in the units of the rate series times
    s^(-1/2, 0, +1/2, +1). ``bias_instability=False`` leaves the flat term
    out (B = 0): on records of a minute, where it cannot be told from the
    white term (measured on 40 s of a synthetic IMU, 8 seeds: N reads
    0.63-0.91 of the truth with it, 0.85-0.94 without)."""
    taus_s, adev = np.asarray(taus_s, float), np.asarray(adev, float)
    sel = (taus_s >= tau_range_s[0]) & (taus_s <= tau_range_s[1])
    t, a = taus_s[sel], adev[sel]
    w = 1.0 / (2.0 * (np.ones_like(t) if rel_sigma is None else np.asarray(rel_sigma, float)[sel]) * a**2)
    cols = ([3.0 / t**2] if quantization else []) + [1.0 / t] + ([np.ones_like(t)] if bias_instability else []) \
        + ([t / 3.0] if rate_random_walk else [])
    A = np.stack(cols, axis=1) * w[:, None]
    c, *_ = np.linalg.lstsq(A, a**2 * w, rcond=None)
    c = np.maximum(c, 0.0)
    q = float(np.sqrt(c[0])) if quantization else 0.0
    c = c[1:] if quantization else c
    if not bias_instability:
        c = np.insert(c, 1, 0.0)
    return {"N": float(np.sqrt(c[0])), "B": float(np.sqrt(c[1]) / FLICKER_FLOOR),
            "K": float(np.sqrt(c[2])) if rate_random_walk else 0.0, "Q": q}
