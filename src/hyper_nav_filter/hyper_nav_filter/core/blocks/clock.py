"""Receiver clock block ``clk`` = [bias b (m), drift d (m/s)] (seed 004 eqs. 1-4):
b' = d + w_b, d' = w_d. The nominal bias integrates the drift between updates.
It couples into no navigation error (only pseudorange models see it)."""
from __future__ import annotations

import numpy as np

from ..params import FLOAT, nonneg, positive
from .base import Block, NoiseInput


class ReceiverClock(Block):
    name, size = "clk", 2
    description = "receiver clock bias (m) and drift (m/s) error"
    PARAMS = (
        positive("clock_bias_sigma_m", FLOAT, 100.0, "initial receiver clock bias 1-sigma (m)"),
        positive("clock_drift_sigma_mps", FLOAT, 1.0, "initial receiver clock drift 1-sigma (m/s)"),
        nonneg("clock_bias_psd_m2ps", FLOAT, 0.1, "clock bias random-walk PSD (m^2/s)"),
        nonneg("clock_drift_psd_m2ps3", FLOAT, 0.01, "clock drift random-walk PSD (m^2/s^3)"),
    )

    def prior_sigma(self, cfg):
        return np.array([cfg.clock_bias_sigma_m, cfg.clock_drift_sigma_mps])

    def self_dynamics(self, cfg):
        return np.array([[0.0, 1.0], [0.0, 0.0]])

    def noise(self, cfg):
        return (NoiseInput("w_clk", np.array([cfg.clock_bias_psd_m2ps, cfg.clock_drift_psd_m2ps3]), "self", np.eye(2)),)

    def propagate(self, value, dt_s, cfg):
        return np.array([value[0] + value[1] * dt_s, value[1]])
