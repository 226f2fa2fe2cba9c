"""GNSS range-error blocks of the tightly coupled filter.

``rb`` (16 slots) / ``rb32`` (32 slots): per-satellite pseudorange biases,
each a first-order Gauss-Markov process (Gelb 1974, Table 3.8-1; Groves
2013, 14.2.7 "range-domain error states"):

    d/dt b_j = -b_j / tau + w_j,   E[w_j w_j] = 2 sigma^2 / tau

the part of a pseudorange error the receiver's broadcast corrections leave
that is correlated over minutes (residual ionosphere, broadcast orbit and
clock, troposphere). Weighting such errors as white noise makes the filter
average them away as if independent, which they are not: its covariance
shrinks far below its error (seed 004 realistic world: position NEES ~500
before these states). The state layout is static, so the block is a pool of
slots; the ``gnss_raw`` source assigns a slot to each satellite it uses
(the lowest free one, else the slot of the satellite unseen longest once
unseen for more than ``range_bias_release_s``; a satellite keeps its slot and
bias state through a loss of lock until another takes it:
``raw_to_pseudoranges.RangeBiasSlots``) and resets a slot when it changes hands
(its row and column of P zeroed, variance sigma^2, nominal value 0:
``ErrorStateKF.apply_resets``). A satellite that finds no free slot has
sigma^2 added to its measurement variance instead (white: counted).

``isb``: inter-system biases of the receiver clock, Galileo, BeiDou and
QZSS against the GPS clock bias of ``clk`` [m] (receiver hardware delays
and the GST/BDT-GPST offsets), random walks: multi-constellation real data
have them (TLSE: +7 m Galileo, +37 m BeiDou).
"""
from __future__ import annotations

import numpy as np

from ..params import FLOAT, nonneg, positive
from .base import Block, NoiseInput, gauss_markov_psd


class RangeBiases(Block):
    name, size = "rb", 16
    description = "pseudorange bias per satellite slot (m), first-order Gauss-Markov"
    PARAMS = (
        # measured on seed 004's realistic world (tc_consistency --measure: pooled RMS 2.22 m of the errors the
        # broadcast corrections leave; a Gauss-Markov fit over 120-400 s lags gives 940-2600 s); the defaults of
        # filter.config.range_errors 'states' (issue 37 item 5, docs/gnss_real_data.md)
        positive("range_bias_sigma_m", FLOAT, 2.2, "steady-state 1-sigma of a satellite's range bias (m)"),
        positive("range_bias_tau_s", FLOAT, 1500.0, "correlation time of the range biases (s)"),
    )

    def prior_sigma(self, cfg):
        return np.full(self.size, cfg.range_bias_sigma_m)

    def self_dynamics(self, cfg):
        return -np.eye(self.size) / cfg.range_bias_tau_s

    def noise(self, cfg):
        psd = np.full(self.size, float(gauss_markov_psd(cfg.range_bias_sigma_m, cfg.range_bias_tau_s)))
        return (NoiseInput("w_rb", psd, "self", np.eye(self.size)),)

    def propagate(self, value, dt_s, cfg):
        return value * np.exp(-dt_s / cfg.range_bias_tau_s)


class RangeBiases32(RangeBiases):
    name, size = "rb32", 32
    PARAMS = ()                     # the parameters of rb


class InterSystemBias(Block):
    name, size = "isb", 3
    description = "receiver inter-system bias of Galileo, BeiDou, QZSS vs GPS (m), random walk"
    SYSTEMS = ("E", "C", "J")
    PARAMS = (
        positive("isb_sigma_m", FLOAT, 100.0, "initial 1-sigma of the inter-system biases (m)"),
        nonneg("isb_psd_m2ps", FLOAT, 1e-4, "inter-system bias random-walk PSD (m^2/s)"),
    )

    def prior_sigma(self, cfg):
        return np.full(self.size, cfg.isb_sigma_m)

    def noise(self, cfg):
        return (NoiseInput("w_isb", np.full(self.size, cfg.isb_psd_m2ps), "self", np.eye(self.size)),)


RANGE_BIAS_BLOCKS = ("rb", "rb32")
