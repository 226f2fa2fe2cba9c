"""Pseudorange and Doppler observables for a moving receiver (seed 004 eq. 10).

    rho = |R3(we tau) r_sat(t_tx) - r_rx(t)| + c (dt_rx - dt_sat + TGD-term)
          + I + T + noise,
with t the true reception time (continuous GPST), tau the light time (iterated,
Sagnac correction = rotation of the Earth-fixed frame during transit, R3 is the
frame rotation about z by we*tau), dt_sat the broadcast satellite clock (incl.
the relativistic term) and the single-frequency group delay: dt_sat(L1 C/A) =
dt_sat - TGD (IS-GPS-200 20.3.3.3.3.2), dt_sat(B1I) = dt_sat - TGD1.

Pseudorange rate: exact time derivative of the same model,
    rho_dot = u.(R3 v_sat - v_rx) / g + c (dt_rx_dot - dt_sat_dot),
    g = 1 - u.(we R3' r_sat - R3 v_sat)/c   (d tau/dt = rho_dot/c, ~1e-5 relative,
    i.e. up to 4 cm/s if ignored); iono/tropo rates neglected.
Doppler [Hz] = -rho_dot / lambda (positive when approaching), L1 1575.42 MHz,
B1I 1561.098 MHz. ``geometric_doppler_hz`` is the clock-free part used by the
lock model.

Noise: pseudorange sigma follows seed 004 eq. 11, D_noise = 0.11 + 0.13
exp(-theta/4) [m] with theta read as elevation in degrees; rate noise is a
user sigma (default 0.05 m/s). The receiver clock is a two-state random walk
(bias, drift) with Allan parameters h0, h-2 (Brown & Hwang): spectral densities
S_b = h0/2 c^2 [m^2/s], S_d = 2 pi^2 h-2 c^2 [m^2/s^3].
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_gnss import earth
# receiver-side models live in the filter package (the filter needs them, and
# it must not import the simulator); re-exported here for existing users
from hyper_nav_gnss.orbits.ephemeris import C_MPS
from hyper_nav_gnss.geometry import elevation_azimuth, satellite_states_at_reception
from hyper_nav_gnss.corrections.propagation import CARRIER_HZ, hopfield_delay_m, klobuchar_delay_m


def pr_sigma_m(el_rad, a_m=0.11, b_m=0.13, el0_deg=4.0):
    """Seed 004 eq. 11 thermal-noise model a + b exp(-E/E0) [m], E in degrees."""
    return a_m + b_m * np.exp(-np.rad2deg(np.asarray(el_rad)) / el0_deg)


@dataclass
class ClockModel:
    """Two-state receiver clock (bias [m], drift [m/s]) driven by white noise
    with Allan parameters h0 [s] and h_m2 [1/s] (TCXO-class defaults)."""
    h0: float = 2e-19
    h_m2: float = 2e-20

    def q_matrix(self, dt_s):
        """Discrete process-noise covariance [m^2, m^2/s; m^2/s, m^2/s^2] over dt_s."""
        sb = self.h0 / 2.0 * C_MPS ** 2
        sd = 2.0 * np.pi ** 2 * self.h_m2 * C_MPS ** 2
        return np.array([[sb * dt_s + sd * dt_s ** 3 / 3.0, sd * dt_s ** 2 / 2.0],
                         [sd * dt_s ** 2 / 2.0, sd * dt_s]])

    def simulate(self, t_s, rng: np.random.Generator, bias0_m=0.0, drift0_mps=0.0):
        """Clock bias [m] and drift [m/s] sampled at times t_s (ascending)."""
        t = np.asarray(t_s, float)
        x = np.array([bias0_m, drift0_mps], float)
        out = np.empty((t.size, 2))
        out[0] = x
        for k in range(1, t.size):
            dt = t[k] - t[k - 1]
            L = np.linalg.cholesky(self.q_matrix(dt))
            x = np.array([x[0] + dt * x[1], x[1]]) + L @ rng.standard_normal(2)
            out[k] = x
        return out[:, 0], out[:, 1]


@dataclass
class Observables:
    """Per-satellite arrays at one epoch (N satellites).
    t_tag_s: receiver time tag = t + rx_clk_bias/c [GPST s]."""
    t_tag_s: float
    sat_ids: list
    pseudorange_m: np.ndarray
    pseudorange_rate_mps: np.ndarray
    doppler_hz: np.ndarray
    geometric_range_m: np.ndarray          # |R3 r_sat(t_tx) - r_rx|
    geometric_rate_mps: np.ndarray         # clock-free range rate
    geometric_doppler_hz: np.ndarray       # -geometric_rate / lambda
    carrier_hz: np.ndarray
    el_rad: np.ndarray
    az_rad: np.ndarray
    r_sat_e_m: np.ndarray                  # true, at transmit time, in ECEF(t_tx)
    v_sat_e_mps: np.ndarray
    sat_clk_bias_m: np.ndarray             # true c dt_sat incl. relativity, minus c TGD
    sat_clk_drift_mps: np.ndarray
    iono_m: np.ndarray                     # the receiver's broadcast models (what it corrects)
    tropo_m: np.ndarray
    tau_s: np.ndarray
    pr_sigma_m: np.ndarray
    rate_sigma_mps: np.ndarray
    iono_true_m: np.ndarray                # the delays the signal went through (world)
    tropo_true_m: np.ndarray


def compute_observables(ephs, t_gpst_s, r_rx_e_m, v_rx_e_mps, rx_clk_bias_m=0.0, rx_clk_drift_mps=0.0,
                        iono=None, tropo=True, rng: np.random.Generator | None = None,
                        rate_sigma_mps=0.05, pr_sigma_fn=pr_sigma_m, world=None):
    """Observables of satellites ``ephs`` for a receiver at ECEF r [m], v [m/s]
    (Earth-fixed frame) at true time ``t_gpst_s`` (continuous GPST).

    iono: None (off) or {'G': (alpha, beta), 'C': (alpha, beta)} Klobuchar sets;
    tropo: apply Hopfield (quartic height model); these are the receiver's
    broadcast models, returned in ``iono_m`` / ``tropo_m`` (what it corrects).
    world: the :class:`.world.GnssWorld` the signals go through (true
    ionosphere, troposphere, orbits and clocks); None = the perfect model
    (the broadcast models and records are the truth). rng: None -> noise-free.
    Sigmas are returned either way."""
    r_rx = np.asarray(r_rx_e_m, float)
    v_rx = np.asarray(v_rx_e_mps, float)
    if world is None:
        from .world import GnssWorld
        world = GnssWorld.perfect(iono, tropo)
    r_s, v_s, cb, cd, tau, R, dR = satellite_states_at_reception(ephs, t_gpst_s, r_rx)
    tgd = np.array([e.tgd for e in ephs])
    # the truth: broadcast states + (true - broadcast) of the world
    r_s, v_s, sat_clk_m, sat_drift_mps = world.satellite_truth(ephs, t_gpst_s, r_s, v_s, C_MPS * (cb - tgd),
                                                               C_MPS * cd)
    rr = np.einsum("kij,kj->ki", R, r_s)
    vr = np.einsum("kij,kj->ki", R, v_s)
    d = rr - r_rx
    rng_geo = np.linalg.norm(d, axis=1)
    u = d / rng_geo[:, None]
    g = 1.0 - np.einsum("ki,ki->k", u, np.einsum("kij,kj->ki", dR, r_s) - vr) / C_MPS
    rate_geo = np.einsum("ki,ki->k", u, vr - v_rx) / g
    el, az = elevation_azimuth(r_rx, rr)
    lat, lon, alt = earth.ecef_to_geodetic(r_rx)
    f = np.array([CARRIER_HZ[e.system] for e in ephs])
    n = len(ephs)
    iono_m, iono_true_m = np.zeros(n), np.zeros(n)
    if iono is not None:
        for k, e in enumerate(ephs):
            if e.system in iono:
                a, b = iono[e.system]
                iono_m[k] = klobuchar_delay_m(a, b, lat, lon, max(el[k], 0.0), az[k], t_gpst_s, f[k])
    if world.ionosphere is not None:
        systems = np.array([e.system for e in ephs])
        for sys_ in set(systems.tolist()):
            sel = systems == sys_
            iono_true_m[sel] = world.ionosphere.slant_delay_m(sys_, lat, lon, alt, el[sel], az[sel], t_gpst_s,
                                                              f[sel])
    tropo_m = hopfield_delay_m(np.maximum(el, 0.0), alt)[0] if tropo else np.zeros(n)
    tropo_true_m = (world.troposphere.slant_delay_m(lat, lon, alt, el, t_gpst_s) if world.troposphere is not None
                    else np.zeros(n))
    sig_pr = pr_sigma_fn(el)
    sig_rate = np.full(n, float(rate_sigma_mps))
    pr = rng_geo + rx_clk_bias_m - sat_clk_m + iono_true_m + tropo_true_m
    prr = rate_geo + rx_clk_drift_mps - sat_drift_mps
    if rng is not None:
        pr = pr + sig_pr * rng.standard_normal(pr.size)
        prr = prr + sig_rate * rng.standard_normal(prr.size)
    lam = C_MPS / f
    return Observables(t_gpst_s + rx_clk_bias_m / C_MPS, [e.sat_id for e in ephs], pr, prr, -prr / lam,
                       rng_geo, rate_geo, -rate_geo / lam, f, el, az, r_s, v_s, sat_clk_m, sat_drift_mps,
                       iono_m, tropo_m, tau, sig_pr, sig_rate, iono_true_m, tropo_true_m)
