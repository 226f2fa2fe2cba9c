"""Early-warning radar measurements of the vehicle (seed 002 section 3.2).

The radar reports the vehicle's altitude, longitude and latitude with zero-mean
Gaussian white noise of standard deviation 2000 m, 0.01 rad and 0.01 rad
(the paper's values, the defaults here), at a configurable rate. Works with
any trajectory offering ``truth(t)`` (``Trajectory`` or ``DynamicTrajectory``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RadarMeasurements:
    t_s: np.ndarray
    alt_m: np.ndarray
    lon_rad: np.ndarray
    lat_rad: np.ndarray

    def as_array(self) -> np.ndarray:
        """(N, 3) rows z = [h, theta, phi] (altitude, longitude, latitude), the
        paper's measurement vector."""
        return np.stack([self.alt_m, self.lon_rad, self.lat_rad], axis=-1)


@dataclass(frozen=True)
class EarlyWarningRadar:
    rate_hz: float = 1.0
    sigma_alt_m: float = 2000.0
    sigma_lon_rad: float = 0.01
    sigma_lat_rad: float = 0.01

    def __post_init__(self):
        for name in ("rate_hz", "sigma_alt_m", "sigma_lon_rad", "sigma_lat_rad"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0) or (name == "rate_hz" and v == 0):
                raise ValueError(f"radar.{name}: must be a {'positive' if name == 'rate_hz' else 'non-negative'} "
                                 f"number, got {v!r}")

    @property
    def covariance(self) -> np.ndarray:
        """Measurement noise covariance R of z = [h, theta, phi]."""
        return np.diag([self.sigma_alt_m**2, self.sigma_lon_rad**2, self.sigma_lat_rad**2])

    def epochs(self, duration_s: float, t0_s: float = 0.0) -> np.ndarray:
        """Measurement epochs t0, t0 + 1/rate, ... <= duration."""
        n = int(np.floor((duration_s - t0_s) * self.rate_hz + 1e-9)) + 1
        return t0_s + np.arange(n) / self.rate_hz

    def measure(self, trajectory, t_s, rng: np.random.Generator) -> RadarMeasurements:
        """Noisy measurements at the epochs t_s (the caller's seeded Generator
        makes them reproducible). Longitude is wrapped to [-pi, pi)."""
        t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
        tr = trajectory.truth(t_s)
        n = rng.standard_normal((len(t_s), 3))
        lon = tr.lon_rad + self.sigma_lon_rad * n[:, 1]
        return RadarMeasurements(t_s, tr.alt_m + self.sigma_alt_m * n[:, 0],
                                 np.mod(lon + np.pi, 2 * np.pi) - np.pi,
                                 tr.lat_rad + self.sigma_lat_rad * n[:, 2])

    def measure_flight(self, trajectory, rng: np.random.Generator, t0_s: float = 0.0) -> RadarMeasurements:
        """Measurements over the whole flight at the radar rate."""
        return self.measure(trajectory, self.epochs(trajectory.duration_s, t0_s), rng)
