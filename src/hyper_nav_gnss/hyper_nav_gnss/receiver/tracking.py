"""Tracking-loop simulation of a GNSS receiver channel bank at 1 kHz: carrier
(3rd-order PLL with 2nd-order FLL assist), carrier-aided code (1st-order DLL),
lock detectors, C/N0 estimator and the re-acquisition search, unaided or
aided by a navigation solution.

Closed forms (Kaplan & Hegarty, *Understanding GPS*, 2nd ed., sec. 5.6
"Measurement errors and tracking thresholds"; Groves, *Principles of GNSS,
Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed., sec. 9.3):

* PLL thermal noise (K&H sec. 5.6):
  sigma_tPLL = 360/(2 pi) sqrt(B_n / (C/N0) (1 + 1 / (2 T C/N0))) [deg].
* PLL dynamic stress (K&H sec. 5.6 with Table 5.6): n-th order loop,
  theta_e = (d^n R / dt^n) / w0^n, w0 = B_n / 0.53 (2nd), B_n / 0.7845 (3rd):
  theta_e2 = 0.2809 R''/B_n^2, theta_e3 = 0.4828 R'''/B_n^3 (R in deg of phase).
* PLL rule of thumb: 3 sigma_PLL + theta_e <= 45 deg (Costas, K&H sec. 5.6).
* FLL thermal noise (K&H sec. 5.6): sigma_tFLL = 1/(2 pi T)
  sqrt(4 F B_n / (C/N0) (1 + 1 / (T C/N0))) [Hz], F = 1 at high C/N0, 2 near
  threshold; dynamic stress of a 2nd-order FLL f_e = R'''/(360 w0^2) [Hz];
  rule 3 sigma_tFLL + f_e <= 1/(4T) [Hz].
* DLL thermal noise (K&H sec. 5.6, noncoherent early-minus-late power, wide
  front end): sigma_tDLL = sqrt(B_n d / (2 C/N0) (1 + 2 / (T C/N0 (2 - d))))
  [chips]; rule 3 sigma_DLL + R_e <= d/2 [chips].

Simulation (:func:`track_block`, one numba kernel; its pure-Python twin
``track_block.py_func`` is the reference that a test compares it with). Per
1 ms and channel, the prompt correlator I + jQ = a exp(j e) + n with unit
variance noise per component, a = sqrt(2 T_1ms C/N0) sinc(df T_1ms) R(eps) (the
thermal-noise model: post-correlation SNR a^2/2 = C/N0 T), e the carrier phase
error at mid interval, df the frequency error, eps the code error [chips],
R(eps) = max(0, 1 - |eps|) (BPSK). Every coherent interval t_coh_s:

* discriminators: Costas atan(Q/I) [rad]; FLL atan(cross/dot)/T [rad/s];
  loop filter of K&H Fig. 5.23 (3rd-order PLL a3 = 1.1, b3 = 2.4 with 2nd-order
  FLL a2 = 1.414; Table 5.6), Euler integrators, FLL assist active only while
  the channel is in frequency lock (mode 1);
* DLL: carrier aided (code error rate = frequency error / (f_carrier /
  f_chip)); discriminator = the noiseless normalised early-minus-late power
  S-curve plus white noise calibrated so that the closed-loop jitter equals
  sigma_tDLL above (a discriminator-level model, no early/late correlators).

Lock detectors on 20 ms blocks of 1 ms samples: phase lock indicator
cos(2 phi) ~ <NBD>/(<NBP> - 2M) (K&H 2nd ed. ch. 5, Van Dierendonck's NBD/NBP, filtered
with time constant pli_tau_s; the noise term 2M of NBP, M = 20 unit-variance
samples, is removed as a receiver does with its noise-floor estimate, else the
indicator's bias rather than the phase error would set the threshold; mode 2 above pli_on, back to 1 below pli_off), and
C/N0 from the narrow-/wide-band power ratio (NWPR, K&H 2nd ed. ch. 5; filtered
mu = <NBP/WBP>, C/N0 = (mu - 1)/(M - mu)/T). A channel whose estimated C/N0 stays
below cn0_drop_dbhz for drop_hold_s is declared lost (mode 0) and searches.

Search (mode 0): serial over q dwells (cells / parallel correlators, per
channel: unaided over the full Doppler x code uncertainty, aided over the
predicted Doppler and code +- k sigma, :mod:`.acquisition`); each dwell sums
k_noncoh coherent sums of acq_t_coh_ms 1-ms samples; the true cell (position
uniform in the sweep, residual Doppler and code offset uniform inside its bin)
holds the signal, the others noise; a sum above the threshold (central chi^2,
2 k_noncoh dof, false-alarm probability per dwell) is a detection, a false
alarm costs penalty_dwells dwells; a true detection hands over to the loops
(mode 1) with the bin's residual errors.

Aided vs unaided is the caller's input ``f_in_hz``: the frequency the loop must
follow, the true Doppler (unaided) or the true minus the navigation-predicted
Doppler (aided: the aiding error, :func:`aiding_doppler_error_hz`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from hyper_nav_gnss.constants import C_MPS
F_L1_HZ = 1575.42e6
CHIP_RATE_CA_HZ = 1.023e6
DT_MS_S = 1e-3

# ---- closed forms ---------------------------------------------------------------------------------


def _cn0_lin(cn0_dbhz):
    c = np.asarray(cn0_dbhz, float)
    if not np.all(np.isfinite(c)):
        raise ValueError(f"cn0_dbhz: expected finite values [dB-Hz], got {cn0_dbhz!r}")
    return 10.0 ** (c / 10.0)


def _pos(name, v):
    v = np.asarray(v, float)
    if not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise ValueError(f"{name}: expected finite values > 0, got {v!r}")
    return v


def pll_thermal_sigma_deg(cn0_dbhz, bn_hz, t_coh_s):
    """K&H 2nd ed. sec. 5.6: 360/(2 pi) sqrt(B_n/(C/N0) (1 + 1/(2 T C/N0))) [deg]."""
    c = _cn0_lin(cn0_dbhz)
    bn, t = _pos("bn_hz", bn_hz), _pos("t_coh_s", t_coh_s)
    return np.rad2deg(np.sqrt(bn / c * (1.0 + 1.0 / (2.0 * t * c))))


W0_FACTOR = {2: 0.53, 3: 0.7845}     # B_n = factor * w0 (K&H Table 5.6)


def pll_dynamic_stress_deg(deriv_deg, bn_hz, order=3):
    """Steady-state phase error [deg] of an order-2 (deriv = R'' [deg/s^2]) or
    order-3 (deriv = R''' [deg/s^3]) PLL: deriv / w0^order (K&H sec. 5.6)."""
    if order not in W0_FACTOR:
        raise ValueError(f"order: expected 2 or 3, got {order!r}")
    w0 = _pos("bn_hz", bn_hz) / W0_FACTOR[order]
    return np.asarray(deriv_deg, float) / w0 ** order


def pll_holds(cn0_dbhz, bn_hz, t_coh_s, dyn_stress_deg=0.0, limit_deg=45.0):
    """Rule of thumb 3 sigma_tPLL + |theta_e| <= 45 deg (Costas, K&H sec. 5.6)."""
    return 3.0 * pll_thermal_sigma_deg(cn0_dbhz, bn_hz, t_coh_s) + np.abs(dyn_stress_deg) <= limit_deg


def pll_threshold_dbhz(bn_hz, t_coh_s, dyn_stress_deg=0.0, limit_deg=45.0):
    """Lowest C/N0 [dB-Hz] meeting :func:`pll_holds` (bisection; inf if none)."""
    lo, hi = -10.0, 80.0
    if not pll_holds(hi, bn_hz, t_coh_s, dyn_stress_deg, limit_deg):
        return math.inf
    for _ in range(60):
        m = 0.5 * (lo + hi)
        lo, hi = (lo, m) if pll_holds(m, bn_hz, t_coh_s, dyn_stress_deg, limit_deg) else (m, hi)
    return hi


def fll_thermal_sigma_hz(cn0_dbhz, bn_hz, t_coh_s, f_factor=1.0):
    """K&H sec. 5.6: 1/(2 pi T) sqrt(4 F B_n/(C/N0) (1 + 1/(T C/N0))) [Hz]."""
    c = _cn0_lin(cn0_dbhz)
    bn, t = _pos("bn_hz", bn_hz), _pos("t_coh_s", t_coh_s)
    return np.sqrt(4.0 * f_factor * bn / c * (1.0 + 1.0 / (t * c))) / (2.0 * np.pi * t)


def fll_dynamic_stress_hz(jerk_deg_s3, bn_hz):
    """2nd-order FLL: f_e = R''' / (360 w0^2) [Hz], w0 = B_n / 0.53 (K&H sec. 5.6)."""
    w0 = _pos("bn_hz", bn_hz) / 0.53
    return np.asarray(jerk_deg_s3, float) / (360.0 * w0 ** 2)


def dll_thermal_sigma_chips(cn0_dbhz, bn_hz, t_coh_s, d_chips):
    """K&H sec. 5.6 (noncoherent E-L power): sqrt(B_n d/(2 C/N0) (1 + 2/(T C/N0 (2-d)))) [chips]."""
    c = _cn0_lin(cn0_dbhz)
    bn, t, d = _pos("bn_hz", bn_hz), _pos("t_coh_s", t_coh_s), _pos("d_chips", d_chips)
    return np.sqrt(bn * d / (2.0 * c) * (1.0 + 2.0 / (t * c * (2.0 - d))))


def epoch_correlation_factor(bn_hz, epoch_interval_s):
    """How much a first-order loop's error sigma must grow for a filter that
    takes its samples every ``epoch_interval_s`` as independent:
    sqrt((1 + rho) / (1 - rho)), rho = exp(-4 B_n dt) the correlation of the
    loop error (time constant 1 / (4 B_n)) between two epochs. A Gauss-Markov
    error sampled at that interval carries, over many samples, the
    information of white samples of this larger sigma (the variance of their
    mean is sigma^2 (1 + rho) / (1 - rho) / N). The aided DLL (0.1 Hz) at
    1 Hz epochs: rho 0.67, factor 2.25 (its simulated code error's lag-1
    correlation measured 0.69, tested)."""
    rho = np.exp(-4.0 * _pos("bn_hz", bn_hz) * _pos("epoch_interval_s", epoch_interval_s))
    return np.sqrt((1.0 + rho) / (1.0 - rho))


# ---- loop parameters and state layout (defined once, by name) --------------------------------------

@dataclass
class LoopConfig:
    """Channel loop parameters (units in the names). Defaults: an unaided
    high-dynamics receiver (wide PLL, 1 ms); :meth:`aided_default` narrows the
    loops and lengthens the integration as aiding allows (data wipe-off or a
    pilot channel assumed for t_coh_s > 20 ms is not needed: <= 20 ms here)."""
    t_coh_s: float = 0.001
    bn_pll_hz: float = 15.0
    bn_fll_hz: float = 2.0
    bn_dll_hz: float = 1.0
    d_chips: float = 0.5
    carrier_hz: float = F_L1_HZ
    chip_rate_hz: float = CHIP_RATE_CA_HZ
    pli_tau_s: float = 0.2
    pli_on: float = 0.6
    pli_off: float = 0.4
    cn0_tau_s: float = 0.5
    cn0_drop_dbhz: float = 12.0
    drop_hold_s: float = 0.5
    acq_t_coh_ms: int = 1
    acq_k_noncoh: int = 1
    acq_pfa: float = 1e-3
    acq_penalty_dwells: float = 10.0
    acq_doppler_bin_hz: float = 500.0
    acq_code_bin_chips: float = 0.5
    nco_limit_hz: float = 0.0
    pli_min_s: float = 0.2
    code_settle_s: float = 1.0
    dll_pull_bn_hz: float = 0.0

    @classmethod
    def aided_default(cls) -> "LoopConfig":
        """Narrow loops behind INS aiding: PLL 3 Hz / 20 ms, DLL 0.1 Hz.
        Reacquisition choices (issue 23, measured on a C/N0 ramp of 1.25 dB/s
        through the aided threshold, ``docs/gnss-receiver-tracking.md``):

        * acquisition 20 ms coherent x 25 noncoherent (0.5 s dwell): the aided
          window is a few cells, all tested in one dwell by the channel's
          correlator array (the caller's ``n_parallel``), so the dwell can be
          long enough to detect near 16 dB-Hz (5 dwells of 100 ms over 2 serial
          cells took 1.6 s median);
        * 2 Hz Doppler bins (a zero-padded FFT over the 20 ms block): the
          handover frequency error is +-1 Hz, inside the 3 Hz PLL's pull-in,
          instead of +-5 Hz that the FLL had to pull at 16-20 dB-Hz;
        * FLL assist practically off (0.05 Hz): the aiding is the frequency
          reference (at 1 Hz the FLL's thermal noise at 20 dB-Hz, about 2 Hz,
          kept the PLL from pulling in; at 0.25 Hz 2.5 % of the channels had no
          phase lock 4 s after the threshold, at 0.05 Hz 1 %);
        * the loop's correction to the aided NCO bounded to +-3 Hz (about 3
          sigma of a 0.2 m/s line-of-sight velocity error, anti-windup on the
          rate integrator): a channel not in phase lock that runs to the bound
          is re-centred on the prediction (at +-10 Hz, 10 % of the channels
          detected near 16 dB-Hz ran away to the bound and stayed in FLL);
        * lock detectors that start as growing-memory averages after a handover
          (no startup transient of the exponential filter), phase lock declared
          once the indicator has averaged 0.2 s (``pli_min_s``) with a 0.3 s
          memory (``pli_tau_s``; 0.5 s added about 0.3 s);
        * code: the handover leaves up to +-0.25 chip (75 m) of code error that
          the 0.1 Hz DLL removes with a 2.5 s time constant; the DLL pulls in at
          2 Hz for ``code_settle_s`` (1 s) after a handover and the pseudorange
          is reported valid only after it (:mod:`.receiver_tracking`): a
          filter fed the unsettled code took tens of metres of error."""
        return cls(t_coh_s=0.02, bn_pll_hz=3.0, bn_fll_hz=0.05, bn_dll_hz=0.1, acq_t_coh_ms=20, acq_k_noncoh=25,
                   acq_doppler_bin_hz=2.0, pli_tau_s=0.3, pli_min_s=0.2, nco_limit_hz=3.0, dll_pull_bn_hz=2.0)

    def validate(self):
        n = round(self.t_coh_s / DT_MS_S)
        if not (np.isfinite(self.t_coh_s) and n >= 1 and abs(n * DT_MS_S - self.t_coh_s) < 1e-9 and n <= 20):
            raise ValueError(f"t_coh_s: expected a whole number of ms in [1, 20] ms, got {self.t_coh_s!r}")
        if not (np.isfinite(self.code_settle_s) and 0 <= self.code_settle_s <= 10):
            raise ValueError(f"code_settle_s: expected in [0, 10] s, got {self.code_settle_s!r}")
        if not (np.isfinite(self.dll_pull_bn_hz) and 0 <= self.dll_pull_bn_hz
                and 4 * self.dll_pull_bn_hz * self.t_coh_s < 1):
            raise ValueError(f"dll_pull_bn_hz: expected 0 (off) or 4 B_n t_coh_s < 1, got {self.dll_pull_bn_hz!r}")
        if not (np.isfinite(self.pli_min_s) and 0 <= self.pli_min_s <= 10):
            raise ValueError(f"pli_min_s: expected in [0, 10] s, got {self.pli_min_s!r}")
        for k in ("bn_pll_hz", "bn_fll_hz", "bn_dll_hz", "carrier_hz", "chip_rate_hz", "pli_tau_s", "cn0_tau_s",
                  "acq_doppler_bin_hz", "acq_code_bin_chips"):
            _pos(k, getattr(self, k))
        if not 0 < self.d_chips < 2:
            raise ValueError(f"d_chips: expected in (0, 2), got {self.d_chips!r}")
        if self.nco_limit_hz < 0 or (self.nco_limit_hz > 0 and self.nco_limit_hz >= 0.25 / self.t_coh_s):
            raise ValueError(f"nco_limit_hz: expected 0 (off) or inside the FLL range 1/(4 t_coh_s) = "
                             f"{0.25 / self.t_coh_s:g} Hz, got {self.nco_limit_hz!r}")
        if not 0 < self.acq_pfa < 1:
            raise ValueError(f"acq_pfa: expected in (0, 1), got {self.acq_pfa!r}")
        if self.acq_t_coh_ms < 1 or self.acq_k_noncoh < 1:
            raise ValueError("acq_t_coh_ms and acq_k_noncoh must be >= 1")
        if 4 * self.bn_dll_hz * self.t_coh_s >= 1 or self.bn_pll_hz * self.t_coh_s > 0.1:
            raise ValueError(f"loop bandwidths too wide for t_coh_s={self.t_coh_s}: need B_n T <= 0.1 (PLL), "
                             f"4 B_n T < 1 (DLL)")
        return self

    def acq_threshold(self) -> float:
        """Threshold on the noncoherent sum S = sum_k |I_k + jQ_k|^2 of coherent
        sums of n = acq_t_coh_ms unit-variance 1-ms samples: S / n ~ chi^2(2K)
        under noise only, so thr = n chi2.isf(acq_pfa, 2K) (:mod:`.acquisition`)."""
        from hyper_nav_gnss.receiver.acquisition import detection_threshold
        return self.acq_t_coh_ms * detection_threshold(self.acq_pfa, self.acq_k_noncoh)

    def as_array(self) -> np.ndarray:
        self.validate()
        p = np.zeros(NP)
        p[P_NCOH] = round(self.t_coh_s / DT_MS_S)
        p[P_W0P] = self.bn_pll_hz / 0.7845
        p[P_W0F] = self.bn_fll_hz / 0.53
        p[P_KDLL] = 4.0 * self.bn_dll_hz * self.t_coh_s
        p[P_BN_DLL] = self.bn_dll_hz
        p[P_D] = self.d_chips
        p[P_RATIO] = self.carrier_hz / self.chip_rate_hz
        p[P_PLI_A] = min(1.0, 0.02 / self.pli_tau_s)
        p[P_PLI_ON], p[P_PLI_OFF] = self.pli_on, self.pli_off
        p[P_CN0_A] = min(1.0, 0.02 / self.cn0_tau_s)
        p[P_DROP] = self.cn0_drop_dbhz
        p[P_HOLD] = self.drop_hold_s
        p[P_ACQ_NCOH] = self.acq_t_coh_ms
        p[P_ACQ_K] = self.acq_k_noncoh
        p[P_ACQ_THR] = self.acq_threshold()
        p[P_ACQ_PEN] = self.acq_penalty_dwells
        p[P_ACQ_DBIN] = self.acq_doppler_bin_hz
        p[P_ACQ_CBIN] = self.acq_code_bin_chips
        p[P_NCO_LIM] = self.nco_limit_hz
        p[P_PLI_MIN] = round(self.pli_min_s / 0.02)
        p[P_SETTLE] = round(self.code_settle_s / 0.02)
        p[P_BN_PULL] = self.dll_pull_bn_hz
        return p


(P_NCOH, P_W0P, P_W0F, P_KDLL, P_BN_DLL, P_D, P_RATIO, P_PLI_A, P_PLI_ON, P_PLI_OFF, P_CN0_A, P_DROP, P_HOLD,
 P_ACQ_NCOH, P_ACQ_K, P_ACQ_THR, P_ACQ_PEN, P_ACQ_DBIN, P_ACQ_CBIN, P_NCO_LIM, P_PLI_MIN, P_SETTLE, P_BN_PULL,
 NP) = range(24)

MODE_SEARCH, MODE_FLL, MODE_PLL = 0, 1, 2
# channel state columns
(S_MODE, S_PHI, S_FNCO, S_VEL, S_ACC, S_EPS, S_IC, S_QC, S_IP, S_QP, S_HAVEP, S_MSC,
 S_BI, S_BQ, S_BW, S_MSB, S_MU, S_NBD, S_NBP, S_LOCKT, S_LOWT, S_CN0E,
 S_CELL, S_TRUE, S_Q, S_DMS, S_DSTAT, S_DK, S_PEN, S_FOFF, S_COFF, S_SEARCHT, S_NACQ, S_NBLK, S_NCOLIM, NS) = range(36)


def new_state(n_ch: int, f0_hz, fdot0_hzps=0.0, q_cells=1.0, cn0_start_dbhz=45.0) -> np.ndarray:
    """Channel states tracking in phase lock at t = 0 (errors zero) with NCO
    frequency f0_hz and rate fdot0_hzps; q_cells = dwells of one search sweep."""
    s = np.zeros((n_ch, NS))
    s[:, S_MODE] = MODE_PLL
    s[:, S_FNCO] = f0_hz
    s[:, S_VEL] = 2 * np.pi * np.asarray(f0_hz, float)
    s[:, S_ACC] = 2 * np.pi * np.asarray(fdot0_hzps, float)
    s[:, S_Q] = np.maximum(1.0, np.ceil(q_cells))
    s[:, S_CN0E] = cn0_start_dbhz
    m = 20.0
    a2 = 2e-3 * 10 ** (cn0_start_dbhz / 10)
    s[:, S_NBD] = m * m * a2
    s[:, S_NBP] = m * m * a2 + 2 * m
    s[:, S_MU] = (m * a2 + 2) / (a2 + 2)
    s[:, S_SEARCHT] = -1.0
    s[:, S_NBLK] = 1e9          # detector averages in steady state
    return s


@njit(cache=True)
def _sinc(x):
    if abs(x) < 1e-9:
        return 1.0
    return math.sin(math.pi * x) / (math.pi * x)


@njit(cache=True)
def _scurve(eps, d):
    """Normalised noncoherent early-minus-late power, slope 1 at 0 (BPSK, R = 1 - |tau|)."""
    e = max(0.0, 1.0 - abs(eps - 0.5 * d))
    l = max(0.0, 1.0 - abs(eps + 0.5 * d))
    den = e * e + l * l
    if den <= 0.0:
        return 0.0
    return 0.5 * (1.0 - 0.5 * d) * (e * e - l * l) / den


@njit(cache=True)
def track_block(f_in_hz, cn0_dbhz, noise, unif, p, s, out_mode, out_phi, out_df, out_eps, out_cn0e):
    """Advance channel states ``s`` (n_ch, NS) over n_ms 1-ms steps. f_in_hz,
    cn0_dbhz (n_ms, n_ch) at the end of each ms; noise (n_ms, n_ch, 3) standard
    normal; unif (n_ms, n_ch, 3) uniform [0, 1); p: :meth:`LoopConfig.as_array`.
    Writes per-ms mode, phase error [rad], frequency error [Hz], code error
    [chips], estimated C/N0 [dB-Hz] into out_* (n_ms, n_ch)."""
    n_ms, n_ch = f_in_hz.shape
    T = 1e-3
    ncoh = int(p[P_NCOH])
    tc = ncoh * T
    w0p, w0f = p[P_W0P], p[P_W0F]
    d = p[P_D]
    ratio = p[P_RATIO]
    kdll = p[P_KDLL]
    for k in range(n_ms):
        for c in range(n_ch):
            f = f_in_hz[k, c]
            cn0 = 10.0 ** (cn0_dbhz[k, c] / 10.0)
            amp1 = math.sqrt(2.0 * T * cn0)
            mode = int(s[c, S_MODE])
            nI, nQ, n3 = noise[k, c, 0], noise[k, c, 1], noise[k, c, 2]
            if mode == 0:
                # ---- search: one ms of the current dwell
                s[c, S_SEARCHT] += T
                if s[c, S_PEN] > 0:
                    s[c, S_PEN] -= 1.0
                else:
                    a = 0.0
                    if s[c, S_CELL] == s[c, S_TRUE]:
                        a = amp1 * abs(_sinc(s[c, S_FOFF] * p[P_ACQ_NCOH] * T)) * max(0.0, 1.0 - abs(s[c, S_COFF]))
                    s[c, S_IC] += a + nI
                    s[c, S_QC] += nQ
                    s[c, S_MSC] += 1.0
                    if s[c, S_MSC] >= p[P_ACQ_NCOH]:
                        s[c, S_DSTAT] += s[c, S_IC] ** 2 + s[c, S_QC] ** 2
                        s[c, S_IC] = 0.0
                        s[c, S_QC] = 0.0
                        s[c, S_MSC] = 0.0
                        s[c, S_DK] += 1.0
                        if s[c, S_DK] >= p[P_ACQ_K]:
                            hit = s[c, S_DSTAT] > p[P_ACQ_THR]
                            s[c, S_DSTAT] = 0.0
                            s[c, S_DK] = 0.0
                            if hit and s[c, S_CELL] == s[c, S_TRUE]:
                                # hand over to the loops with the bin's residual errors
                                s[c, S_MODE] = 1.0
                                s[c, S_FNCO] = f - s[c, S_FOFF]
                                s[c, S_VEL] = 2.0 * math.pi * s[c, S_FNCO]
                                s[c, S_ACC] = 0.0
                                s[c, S_PHI] = 2.0 * math.pi * unif[k, c, 0]
                                s[c, S_EPS] = s[c, S_COFF]
                                s[c, S_HAVEP] = 0.0
                                s[c, S_BI] = 0.0
                                s[c, S_BQ] = 0.0
                                s[c, S_BW] = 0.0
                                s[c, S_MSB] = 0.0
                                s[c, S_NBD] = 0.0
                                s[c, S_NBP] = 40.0
                                s[c, S_LOWT] = 0.0
                                s[c, S_LOCKT] = 0.0
                                s[c, S_NACQ] += 1.0
                                # verification: the C/N0 estimate starts from noise only, so a false
                                # alarm is dropped after drop_hold_s without ever reading as a signal
                                s[c, S_MU] = 1.0
                                s[c, S_CN0E] = -30.0
                                s[c, S_NBLK] = 0.0
                            else:
                                if hit:
                                    s[c, S_PEN] = p[P_ACQ_PEN] * p[P_ACQ_NCOH] * p[P_ACQ_K]
                                s[c, S_CELL] += 1.0
                                if s[c, S_CELL] >= s[c, S_Q]:
                                    s[c, S_CELL] = 0.0
                out_mode[k, c] = s[c, S_MODE]
                out_phi[k, c] = 0.0
                out_df[k, c] = 0.0
                out_eps[k, c] = 0.0
                out_cn0e[k, c] = s[c, S_CN0E]
                continue
            # ---- tracking: one ms of correlation
            df = f - s[c, S_FNCO]
            phi_mid = s[c, S_PHI] + math.pi * df * T
            s[c, S_PHI] += 2.0 * math.pi * df * T
            s[c, S_EPS] += df / ratio * T
            a = amp1 * _sinc(df * T) * max(0.0, 1.0 - abs(s[c, S_EPS]))
            I1 = a * math.cos(phi_mid) + nI
            Q1 = a * math.sin(phi_mid) + nQ
            s[c, S_IC] += I1
            s[c, S_QC] += Q1
            s[c, S_MSC] += 1.0
            # lock detectors on 20 ms blocks
            s[c, S_BI] += I1
            s[c, S_BQ] += Q1
            s[c, S_BW] += I1 * I1 + Q1 * Q1
            s[c, S_MSB] += 1.0
            if s[c, S_MSB] >= 20.0:
                nbp = s[c, S_BI] ** 2 + s[c, S_BQ] ** 2
                nbd = s[c, S_BI] ** 2 - s[c, S_BQ] ** 2
                # growing-memory start after a handover: the cumulative mean of the blocks so far until
                # it reaches the filter's memory (weight 1/n), then the exponential filter
                s[c, S_NBLK] += 1.0
                g = 1.0 / s[c, S_NBLK]
                ap = max(p[P_PLI_A], g)
                s[c, S_NBD] += ap * (nbd - s[c, S_NBD])
                s[c, S_NBP] += ap * (nbp - s[c, S_NBP])
                ac = max(p[P_CN0_A], g)
                s[c, S_MU] += ac * (nbp / max(s[c, S_BW], 1e-12) - s[c, S_MU])
                mu = s[c, S_MU]
                x = (mu - 1.0) / max(20.0 - mu, 1e-9) / T
                s[c, S_CN0E] = 10.0 * math.log10(max(x, 1e-3))
                s[c, S_BI] = 0.0
                s[c, S_BQ] = 0.0
                s[c, S_BW] = 0.0
                s[c, S_MSB] = 0.0
                # noise-bias-corrected indicator: E[NBP] = M^2 a^2 + 2M (unit noise per component)
                pli = s[c, S_NBD] / max(s[c, S_NBP] - 40.0, 0.25 * s[c, S_NBP])
                if mode == 2 and pli < p[P_PLI_OFF]:
                    mode = 1
                elif mode == 1 and pli > p[P_PLI_ON] and s[c, S_NBLK] >= p[P_PLI_MIN]:
                    mode = 2
                    s[c, S_LOCKT] = 0.0
                if s[c, S_CN0E] < p[P_DROP]:
                    s[c, S_LOWT] += 0.02
                else:
                    s[c, S_LOWT] = 0.0
                if s[c, S_LOWT] >= p[P_HOLD]:
                    # loss of lock declared: start the search
                    mode = 0
                    s[c, S_CELL] = 0.0
                    s[c, S_TRUE] = math.floor(unif[k, c, 0] * s[c, S_Q])
                    s[c, S_FOFF] = (unif[k, c, 1] - 0.5) * p[P_ACQ_DBIN]
                    s[c, S_COFF] = (unif[k, c, 2] - 0.5) * p[P_ACQ_CBIN]
                    s[c, S_DMS] = 0.0
                    s[c, S_DSTAT] = 0.0
                    s[c, S_DK] = 0.0
                    s[c, S_PEN] = 0.0
                    s[c, S_IC] = 0.0
                    s[c, S_QC] = 0.0
                    s[c, S_MSC] = 0.0
                    s[c, S_SEARCHT] = 0.0
                    s[c, S_LOCKT] = 0.0
                s[c, S_MODE] = mode
            if mode == 2:
                s[c, S_LOCKT] += T
            if mode != 0 and s[c, S_MSC] >= ncoh:
                # ---- discriminators and loop filters, once per coherent interval
                Ic, Qc = s[c, S_IC], s[c, S_QC]
                ep = math.atan(Qc / Ic) if Ic != 0.0 else math.copysign(0.5 * math.pi, Qc)
                ef = 0.0
                if mode == 1 and s[c, S_HAVEP] > 0.0:
                    cross = s[c, S_IP] * Qc - s[c, S_QP] * Ic
                    dot = s[c, S_IP] * Ic + s[c, S_QP] * Qc
                    ef = (math.atan(cross / dot) if dot != 0.0 else math.copysign(0.5 * math.pi, cross)) / tc
                wf = w0f if mode == 1 else 0.0
                s[c, S_ACC] += tc * (w0p ** 3 * ep + wf * wf * ef)
                s[c, S_VEL] += tc * (s[c, S_ACC] + 1.1 * w0p * w0p * ep + 1.414 * wf * ef)
                lim = p[P_NCO_LIM]
                if lim > 0.0 and s[c, S_NCOLIM] > lim:      # per channel: the caller's k sigma of the aiding
                    lim = s[c, S_NCOLIM]
                if lim > 0.0:       # aided: correction to the predicted Doppler bounded (f_in is the residual)
                    wl = 2.0 * math.pi * lim
                    if abs(s[c, S_VEL]) >= wl:
                        if mode == 1:
                            # not in phase lock and the loop has run to the bound: re-centre on the
                            # aiding (the prediction is trusted to its covariance, the loop is not)
                            s[c, S_VEL] = 0.0
                        else:
                            s[c, S_VEL] = min(max(s[c, S_VEL], -wl), wl)
                        s[c, S_ACC] = 0.0           # anti-windup: no rate integrated against the bound
                s[c, S_FNCO] = (s[c, S_VEL] + 2.4 * w0p * ep) / (2.0 * math.pi)
                # carrier-aided DLL (pull-in bandwidth for code_settle_s after a handover, if set)
                bn_d, kd = p[P_BN_DLL], kdll
                if p[P_BN_PULL] > bn_d and s[c, S_NBLK] < p[P_SETTLE]:
                    bn_d = p[P_BN_PULL]
                    kd = 4.0 * bn_d * tc
                cn0_eff = max(cn0 * _sinc(df * T) ** 2, 1e-6)
                sig2 = bn_d * d / (2.0 * cn0_eff) * (1.0 + 2.0 / (tc * cn0_eff * (2.0 - d)))
                sd = math.sqrt(sig2 * (2.0 - kd) / kd)
                s[c, S_EPS] -= kd * (_scurve(s[c, S_EPS], d) + sd * n3)
                s[c, S_IP], s[c, S_QP] = Ic, Qc
                s[c, S_HAVEP] = 1.0
                s[c, S_IC] = 0.0
                s[c, S_QC] = 0.0
                s[c, S_MSC] = 0.0
            out_mode[k, c] = s[c, S_MODE]
            out_phi[k, c] = s[c, S_PHI]
            out_df[k, c] = f - s[c, S_FNCO]
            out_eps[k, c] = s[c, S_EPS]
            out_cn0e[k, c] = s[c, S_CN0E]


@dataclass
class TrackOutput:
    """Per-ms outputs, arrays (n_ms, n_ch): mode (0 search, 1 FLL/code, 2 phase
    lock), carrier phase error [rad], frequency error [Hz], code error [chips],
    estimated C/N0 [dB-Hz]."""
    mode: np.ndarray
    phase_err_rad: np.ndarray
    freq_err_hz: np.ndarray
    code_err_chips: np.ndarray
    cn0_est_dbhz: np.ndarray


class ChannelBank:
    """n_ch channels sharing one :class:`LoopConfig`; :meth:`run` advances them
    over a block of 1-ms inputs. Randomness from the ``rng`` passed in."""

    def __init__(self, config: LoopConfig, n_ch: int, f0_hz, fdot0_hzps=0.0, q_cells=1.0,
                 cn0_start_dbhz=45.0, compiled=True):
        self.cfg = config
        self.p = config.as_array()
        self.state = new_state(n_ch, f0_hz, fdot0_hzps, q_cells, cn0_start_dbhz)
        self._kernel = track_block if compiled else track_block.py_func

    def set_search_cells(self, q_cells):
        """Dwells per sweep (used from the next search start)."""
        self.state[:, S_Q] = np.maximum(1.0, np.ceil(np.asarray(q_cells, float)))

    def start_search(self, rng: np.random.Generator, channels=None):
        """Declare loss of lock now on ``channels`` (all by default): the search
        starts as in the kernel (true cell uniform in the sweep, residual
        Doppler and code offsets uniform inside the cell)."""
        s = self.state
        idx = np.arange(s.shape[0]) if channels is None else np.asarray(channels)
        u = rng.random((idx.size, 3))
        s[idx, S_MODE] = MODE_SEARCH
        for col in (S_CELL, S_DMS, S_DSTAT, S_DK, S_PEN, S_IC, S_QC, S_MSC, S_SEARCHT, S_LOCKT):
            s[idx, col] = 0.0
        s[idx, S_TRUE] = np.floor(u[:, 0] * s[idx, S_Q])
        s[idx, S_FOFF] = (u[:, 1] - 0.5) * self.p[P_ACQ_DBIN]
        s[idx, S_COFF] = (u[:, 2] - 0.5) * self.p[P_ACQ_CBIN]

    def run(self, f_in_hz, cn0_dbhz, rng: np.random.Generator, noise=None, unif=None) -> TrackOutput:
        f = np.ascontiguousarray(f_in_hz, float)
        cn = np.ascontiguousarray(cn0_dbhz, float)
        if f.shape != cn.shape or f.ndim != 2 or f.shape[1] != self.state.shape[0]:
            raise ValueError(f"f_in_hz and cn0_dbhz: expected (n_ms, {self.state.shape[0]}), got {f.shape}, {cn.shape}")
        if not np.all(np.isfinite(cn)):
            raise ValueError("cn0_dbhz: non-finite C/N0 (NaN or inf) in the input")
        if not np.all(np.isfinite(f)):
            raise ValueError("f_in_hz: non-finite frequency in the input")
        n, m = f.shape
        if noise is None:
            noise = rng.standard_normal((n, m, 3))
        if unif is None:
            unif = rng.random((n, m, 3))
        outs = [np.empty((n, m)) for _ in range(5)]
        self._kernel(f, cn, noise, unif, self.p, self.state, *outs)
        return TrackOutput(*outs)


def aiding_doppler_error_hz(u_los_enu, cov_vel_enu_m2ps2, t_s, tau_s, rng, carrier_hz=F_L1_HZ,
                            clk_drift_sigma_mps=0.0):
    """Error of the navigation-predicted Doppler [Hz] per epoch and satellite:
    -(u . dv)/lambda - d_clk/lambda, dv a first-order Gauss-Markov velocity error
    (ENU, time constant tau_s) whose covariance at each epoch is
    cov_vel_enu_m2ps2 (3,3) or (n_t,3,3) (the fused state's velocity covariance);
    u_los_enu (n_t, n_sat, 3) or (n_sat, 3). Raises ValueError on a covariance
    that is not finite, symmetric and positive semidefinite."""
    t = np.asarray(t_s, float)
    P = np.asarray(cov_vel_enu_m2ps2, float)
    if P.ndim == 2:
        P = np.broadcast_to(P, (t.size, 3, 3))
    if P.shape != (t.size, 3, 3) or not np.all(np.isfinite(P)):
        raise ValueError(f"cov_vel_enu_m2ps2: expected finite (3,3) or ({t.size},3,3), got shape {P.shape}")
    if np.max(np.abs(P - np.swapaxes(P, 1, 2))) > 1e-9 * max(1.0, np.max(np.abs(P))):
        raise ValueError("cov_vel_enu_m2ps2: not symmetric")
    w, V = np.linalg.eigh(P)
    if np.any(w < -1e-12 * max(1.0, np.max(np.abs(w)))):
        raise ValueError(f"cov_vel_enu_m2ps2: not positive semidefinite (min eigenvalue {w.min():.3g})")
    if not (np.isfinite(tau_s) and tau_s > 0):
        raise ValueError(f"tau_s: expected > 0, got {tau_s!r}")
    L = V * np.sqrt(np.maximum(w, 0.0))[:, None, :]
    z = rng.standard_normal(3)
    x = np.empty((t.size, 3))
    x[0] = z
    for k in range(1, t.size):
        phi = math.exp(-(t[k] - t[k - 1]) / tau_s)
        z = phi * z + math.sqrt(1 - phi * phi) * rng.standard_normal(3)
        x[k] = z
    dv = np.einsum("kij,kj->ki", L, x)
    u = np.asarray(u_los_enu, float)
    if u.ndim == 2:
        u = np.broadcast_to(u, (t.size,) + u.shape)
    clk = clk_drift_sigma_mps * rng.standard_normal() if clk_drift_sigma_mps > 0 else 0.0
    return -(np.einsum("kni,ki->kn", u, dv) + clk) * carrier_hz / C_MPS


__all__ = ["LoopConfig", "ChannelBank", "TrackOutput", "track_block", "new_state", "aiding_doppler_error_hz",
           "pll_thermal_sigma_deg", "pll_dynamic_stress_deg", "pll_holds", "pll_threshold_dbhz",
           "fll_thermal_sigma_hz", "fll_dynamic_stress_hz", "dll_thermal_sigma_chips",
           "MODE_SEARCH", "MODE_FLL", "MODE_PLL"]
