"""Datasheet units to SI, converted once at the edge (STYLE pattern 6)."""
import numpy as np

from hyper_nav_gnss.earth import G0_MPS2

DEG = np.pi / 180.0
ARCMIN = DEG / 60.0
HOUR_S = 3600.0


def deg_per_hr(x):
    """deg/h -> rad/s."""
    return np.asarray(x, dtype=float) * DEG / HOUR_S


def deg_per_sqrt_hr(x):
    """Angle random walk deg/sqrt(h) -> rad/sqrt(s) (PSD sqrt of rate noise)."""
    return np.asarray(x, dtype=float) * DEG / np.sqrt(HOUR_S)


def ug(x):
    """micro-g -> m/s^2."""
    return np.asarray(x, dtype=float) * 1e-6 * G0_MPS2


def ug_per_sqrt_hz(x):
    """Velocity random walk ug/sqrt(Hz) -> m/s/sqrt(s)."""
    return np.asarray(x, dtype=float) * 1e-6 * G0_MPS2


def arcmin(x):
    return np.asarray(x, dtype=float) * ARCMIN
