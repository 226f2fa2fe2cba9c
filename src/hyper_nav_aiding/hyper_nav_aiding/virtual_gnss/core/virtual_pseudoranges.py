"""Virtual pseudoranges and rates (seed 004 section 2.3, eqs. 8-11).

For a satellite whose tracking loop lost lock, with its stored broadcast
record and an extrapolated vehicle (antenna) position r_e, velocity v_e and
receiver clock (bias b, drift d):

    eq. 8   satellite orbit from the stored ephemeris (IS-GPS-200 Table 20-IV,
            :func:`hyper_nav_gnss.orbits.ephemeris.satellite_position_ecef`),
            at the transmit time of the light-time solution, with the Sagnac
            rotation (:func:`~hyper_nav_gnss.geometry.satellite_states_at_reception`);
    eq. 10  rho_GPS = |r_sat - r_e| + D_iono + D_tropo + D_satclk + D_noise,
    eq. 11  D_iono = Klobuchar (broadcast alpha, beta), D_tropo = Hopfield,
            D_satclk = af0 + af1 (t - toc) + af2 (t - toc)^2 (+ relativity),
            D_noise = 0.11 + 0.13 exp(-theta / 4) [m] (theta: elevation, deg).

Sign convention: the result is what the receiver would have *output*
(``hyper_nav_msgs/GnssMeasurements``, :class:`RawGnssEpoch`), so the
satellite clock enters as -c (dt_sat - TGD) and the receiver clock as +b:

    rho_v = |R3(we tau) r_sat(t - tau) - r_e| + b - c (dt_sat - TGD) + I + T + n,
    rate_v = u . (R3 v_sat - v_e) / g + d - c dt_sat' + n_rate

(g the light-time rate factor, as in the simulator's observables). A
consumer corrects it exactly like a real epoch
(:mod:`hyper_nav_filter.core.raw_to_pseudoranges`): the satellite
clock and the broadcast delays cancel, leaving |r_sat - r_e| + b + n. eq. 9's
rho_SINS is the filter's own predicted range.

``noise``: D_noise is the paper's 1-sigma; with an rng a draw is added
(the paper adds it), without one the epoch is noise-free. The sigmas
written into the epoch are the virtual source's own (the fusion node's
declared source uses them as R).
"""
from __future__ import annotations

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_gnss.orbits.ephemeris import C_MPS
from hyper_nav_gnss.geometry import elevation_azimuth, satellite_states_at_reception
from hyper_nav_gnss.corrections.propagation import CARRIER_HZ, hopfield_delay_m, klobuchar_delay_m
from hyper_nav_gnss.observations import RawGnssEpoch
from hyper_nav_filter.core.raw_to_pseudoranges import ReceiverCorrections


def paper_noise_sigma_m(el_rad):
    """Seed 004 eq. 11: D_noise = 0.11 + 0.13 exp(-theta / 4) [m], theta in degrees."""
    return 0.11 + 0.13 * np.exp(-np.rad2deg(np.asarray(el_rad, float)) / 4.0)


def sky(ephs, t_gpst_s: float, r_e_m):
    """Satellite states at reception (light time + Sagnac) seen from r_e:
    (r_sat in ECEF(t) (N,3), v_sat in ECEF(t) (N,3), clock bias [s], drift
    [s/s], elevation, azimuth [rad], light-time rate factor g)."""
    r_e = np.asarray(r_e_m, float)
    r_s, v_s, cb, cd, _, R, dR = satellite_states_at_reception(ephs, t_gpst_s, r_e)
    rr = np.einsum("kij,kj->ki", R, r_s)
    vr = np.einsum("kij,kj->ki", R, v_s)
    d = rr - r_e
    u = d / np.linalg.norm(d, axis=1)[:, None]
    g = 1.0 - np.einsum("ki,ki->k", u, np.einsum("kij,kj->ki", dR, r_s) - vr) / C_MPS
    el, az = elevation_azimuth(r_e, rr)
    return rr, vr, cb, cd, el, az, g


def virtual_epoch(t_s: float, t_rx_gpst_s: float, ephs, r_e_m, v_e_mps, clk_bias_m: float, clk_drift_mps: float,
                  corrections: ReceiverCorrections, pr_sigma_m, rate_sigma_mps, rng: np.random.Generator | None = None,
                  noise_sigma_m=None, rate_noise_sigma_mps=None) -> RawGnssEpoch:
    """Virtual raw epoch (eq. 10) of the satellites ``ephs`` at filter time t_s
    and receiver time tag t_rx_gpst_s (continuous GPST). ``pr_sigma_m`` /
    ``rate_sigma_mps`` (scalar or per satellite) are the sigmas written into
    the epoch; ``noise_sigma_m`` (default eq. 11's D_noise) and
    ``rate_noise_sigma_mps`` (default ``rate_sigma_mps``) the drawn noise (with ``rng``)."""
    r_e = np.asarray(r_e_m, float)
    v_e = np.asarray(v_e_mps, float)
    t_true = t_rx_gpst_s - clk_bias_m / C_MPS
    rr, vr, cb, cd, el, az, g = sky(ephs, t_true, r_e)
    rng_geo = np.linalg.norm(rr - r_e, axis=1)
    u = (rr - r_e) / rng_geo[:, None]
    rate_geo = np.einsum("ki,ki->k", u, vr - v_e) / g
    n = len(ephs)
    lat, lon, alt = earth.ecef_to_geodetic(r_e)
    iono = np.zeros(n)
    if corrections.klobuchar is not None:
        for k, e in enumerate(ephs):
            if e.system in corrections.klobuchar:
                a, b = corrections.klobuchar[e.system]
                iono[k] = klobuchar_delay_m(a, b, lat, lon, max(el[k], 0.0), az[k], t_true, CARRIER_HZ[e.system])
    tropo = hopfield_delay_m(np.maximum(el, 0.0), alt)[0] if corrections.troposphere else np.zeros(n)
    tgd = np.array([e.tgd for e in ephs])
    pr = rng_geo + clk_bias_m - C_MPS * (cb - tgd) + iono + tropo
    rate = rate_geo + clk_drift_mps - C_MPS * cd
    if rng is not None:
        s_pr = paper_noise_sigma_m(el) if noise_sigma_m is None else np.broadcast_to(noise_sigma_m, (n,))
        s_rt = np.broadcast_to(rate_sigma_mps if rate_noise_sigma_mps is None else rate_noise_sigma_mps, (n,))
        pr = pr + s_pr * rng.standard_normal(n)
        rate = rate + s_rt * rng.standard_normal(n)
    return RawGnssEpoch(float(t_s), float(t_rx_gpst_s), tuple(e.system for e in ephs),
                        np.array([e.prn for e in ephs], int), pr,
                        np.broadcast_to(np.asarray(pr_sigma_m, float), (n,)).copy(), rate,
                        np.broadcast_to(np.asarray(rate_sigma_mps, float), (n,)).copy(), np.ones(n, bool))
