"""Acquisition and re-acquisition statistics of a serial (or partly parallel)
search over Doppler x code cells: detection probability from C/N0, search
window size unaided or aided, mean acquisition time.

Detection (Kaplan & Hegarty 2nd ed. ch. 5 acquisition; Groves 2nd ed.
sec. 9.2.1; the standard square-law noncoherent detector): a dwell sums K
noncoherent powers |I + jQ|^2 of coherent integrations of length T. With
unit-variance noise per component the normalised statistic is central
chi^2 with 2K degrees of freedom under noise only and noncentral chi^2 with
2K dof and noncentrality lambda = 2 K T C/N0 L^2 under the signal (L the
amplitude loss from the residual Doppler |sinc(df T)| and code offset
1 - |tau| inside the cell). Threshold: thr = chi2.isf(P_fa, 2K); P_d =
ncx2.sf(thr, 2K, lambda) (scipy.stats).

Mean acquisition time of a serial search of q cells with the signal in one
cell at a uniformly distributed position, P_d and P_fa per dwell, a false
alarm costing K_p further dwells (Holmes, *Coherent Spread Spectrum Systems*,
Wiley 1982, serial-search acquisition; Kaplan & Hegarty 2nd ed. ch. 5):
    E[T] = tau_d (2 + (2 - P_d)(q - 1)(1 + K_p P_fa)) / (2 P_d).
With P_fa = 0, P_d = 1 this is tau_d (q + 1) / 2.

Search windows: unaided, the Doppler half-width is what the receiver cannot
predict (vehicle speed / lambda + clock drift; a hypersonic vehicle at
2.5 km/s: +-13 kHz at L1) and the code is the whole period (1023 chips);
aided, +-k sigma of the navigation solution's predicted Doppler and code phase
(line-of-sight velocity and position sigmas). Cells are Doppler bins of
``doppler_bin_hz`` (about 2/(3T), K&H ch. 5) times code bins of
``code_bin_chips``; ``n_parallel`` cells are tested per dwell.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.stats import chi2, ncx2

from hyper_nav_gnss.constants import C_MPS
F_L1_HZ = 1575.42e6
CHIP_LENGTH_CA_M = C_MPS / 1.023e6
CODE_CHIPS_CA = 1023


def detection_threshold(pfa, k_noncoh):
    """Threshold on sum_k |z_k|^2 (unit variance per component) for false-alarm probability pfa."""
    if not 0 < pfa < 1:
        raise ValueError(f"pfa: expected in (0, 1), got {pfa!r}")
    return float(chi2.isf(pfa, 2 * int(k_noncoh)))


def detection_probability(cn0_dbhz, t_coh_s, k_noncoh, pfa, amp_loss=1.0):
    """P_d of one dwell (module docstring); cn0_dbhz may be an array."""
    c = np.asarray(cn0_dbhz, float)
    if not np.all(np.isfinite(c)):
        raise ValueError(f"cn0_dbhz: expected finite values [dB-Hz], got {cn0_dbhz!r}")
    lam = 2.0 * k_noncoh * t_coh_s * 10 ** (c / 10) * np.asarray(amp_loss, float) ** 2
    return ncx2.sf(detection_threshold(pfa, k_noncoh), 2 * int(k_noncoh), lam)


def mean_dwells(q, pd, pfa, penalty_dwells):
    """Mean number of dwell times to acquire: (2 + (2 - P_d)(q - 1)(1 + K_p P_fa)) / (2 P_d)."""
    pd = np.asarray(pd, float)
    return (2.0 + (2.0 - pd) * (q - 1) * (1.0 + penalty_dwells * pfa)) / (2.0 * pd)


def mean_acquisition_time_s(cn0_dbhz, q, t_coh_s, k_noncoh, pfa, penalty_dwells, doppler_bin_hz=None,
                            code_bin_chips=None, n_grid=41):
    """Mean time to detection [s]. With bin sizes given, averaged over the
    residual Doppler (uniform in +-bin/2) and code offset (uniform in +-bin/2)
    of the true cell, fixed for a whole search (the tracking kernel's model)."""
    tau = t_coh_s * k_noncoh
    if doppler_bin_hz is None:
        return tau * float(mean_dwells(q, detection_probability(cn0_dbhz, t_coh_s, k_noncoh, pfa), pfa,
                                       penalty_dwells))
    u = (np.arange(n_grid) + 0.5) / n_grid - 0.5
    df, dc = np.meshgrid(u * doppler_bin_hz, u * code_bin_chips)
    loss = np.abs(np.sinc(df * t_coh_s)) * (1.0 - np.abs(dc))
    pd = detection_probability(cn0_dbhz, t_coh_s, k_noncoh, pfa, loss)
    return tau * float(np.mean(mean_dwells(q, pd, pfa, penalty_dwells)))


def search_cells(doppler_halfwidth_hz, code_halfwidth_chips, doppler_bin_hz, code_bin_chips, n_parallel=1):
    """Dwells per sweep q = ceil(n_doppler n_code / n_parallel), n_doppler =
    ceil(2 hw_f / bin_f), n_code = ceil(2 hw_c / bin_c) capped at the code period."""
    for k, v in (("doppler_halfwidth_hz", doppler_halfwidth_hz), ("code_halfwidth_chips", code_halfwidth_chips),
                 ("doppler_bin_hz", doppler_bin_hz), ("code_bin_chips", code_bin_chips), ("n_parallel", n_parallel)):
        if not np.all(np.isfinite(v)) or np.any(np.asarray(v) < 0) or (k.endswith("bin_hz") and v <= 0):
            raise ValueError(f"{k}: expected a finite number >= 0, got {v!r}")
    nd = np.maximum(1, np.ceil(2 * np.asarray(doppler_halfwidth_hz, float) / doppler_bin_hz))
    nc = np.maximum(1, np.minimum(np.ceil(2 * np.asarray(code_halfwidth_chips, float) / code_bin_chips),
                                  math.ceil(CODE_CHIPS_CA / code_bin_chips)))
    return np.ceil(nd * nc / n_parallel)


def unaided_doppler_halfwidth_hz(speed_uncertainty_mps, clock_drift_uncertainty_mps=100.0, carrier_hz=F_L1_HZ):
    """Doppler an unaided receiver must search: (speed + clock drift uncertainty) / lambda [Hz]."""
    return (speed_uncertainty_mps + clock_drift_uncertainty_mps) * carrier_hz / C_MPS


def aided_halfwidths(sigma_vel_los_mps, sigma_range_m, k_sigma=3.0, carrier_hz=F_L1_HZ):
    """(Doppler half-width [Hz], code half-width [chips]) of the aided search:
    +-k sigma of the predicted line-of-sight velocity (incl. clock drift) and
    range (incl. clock bias) from the navigation solution's covariance."""
    s_v, s_r = np.asarray(sigma_vel_los_mps, float), np.asarray(sigma_range_m, float)
    if not (np.all(np.isfinite(s_v)) and np.all(np.isfinite(s_r))) or np.any(s_v < 0) or np.any(s_r < 0):
        raise ValueError("aided_halfwidths: sigmas must be finite and >= 0")
    return k_sigma * s_v * carrier_hz / C_MPS, k_sigma * s_r / CHIP_LENGTH_CA_M


__all__ = ["detection_threshold", "detection_probability", "mean_dwells", "mean_acquisition_time_s",
           "search_cells", "unaided_doppler_halfwidth_hz", "aided_halfwidths", "CHIP_LENGTH_CA_M"]
