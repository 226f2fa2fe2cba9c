"""A simulated static GNSS station: code, phase, Doppler and C/N0 of every
satellite above the mask, from real broadcast ephemerides, on the signals an
IGS multi-GNSS receiver tracks, as epochs ``rinex_obs_write`` writes.

Model (the perfect-model world: the broadcast orbits and clocks are the
truth; seed 004 eq. 10 per signal s):

    P_s = |R3(we tau) r_sat(t_tx) - r_rx| + c (dt_r - dt_sv + d_s) + I1 (f1 / f_s)^2 + T + e_s,
    L_s = (P_s - 2 I1 (f1 / f_s)^2) / lambda_s + N_s   (cycles; carrier advance, no noise term),
    D_s = -rho_dot / lambda_s,

with dt_sv the broadcast clock (relativity included), d_s the record's group
delay of signal s (``corrections.signal_delays``: GPS TGD, Galileo BGD of
the I/NAV record, BeiDou TGD1/TGD2), I1 Klobuchar on L1 from the
navigation file's own coefficients, T Hopfield, dt_r a receiver clock
(``observables.ClockModel``), e_s white with seed 004 eq. 11's sigma per
signal, N_s a whole number of cycles per satellite pass and C/N0
30 + 20 sin(elevation) dB-Hz. So a solver with the same broadcast models
recovers the position to the noise (the epochs are tagged in receiver
time on the interval grid: true reception time = tag - dt_r): a file for speed and for checking the
solvers against each other, not for accuracy claims about real stations.
"""
from __future__ import annotations

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_gnss.corrections.propagation import hopfield_delay_m, klobuchar_delay_m
from hyper_nav_gnss.corrections.signal_delays import NoGroupDelay, group_delay_s
from hyper_nav_gnss.geometry import elevation_azimuth, satellite_states_at_reception
from hyper_nav_gnss.orbits.ephemeris import C_MPS, GAL_CLOCK_E1E5B, NearestToe, system_time_s
from hyper_nav_gnss.signals import frequency_hz

from .observables import ClockModel, pr_sigma_m

# the signals an IGS multi-GNSS station records (code C, phase L, Doppler D, strength S of each)
IGS_SIGNALS = {"G": ("1C", "2W", "5Q"), "E": ("1X", "5X", "7X", "8X"), "C": ("2I", "6I", "7I")}
F_L1_HZ = frequency_hz("G", "1C")


def obs_types(signals: dict[str, tuple]) -> dict[str, list[str]]:
    return {s: [k + c for c in codes for k in "CLDS"] for s, codes in signals.items()}


def _by_satellite(nav, systems) -> dict[str, NearestToe]:
    """Each satellite's healthy records (Galileo: those of the E1/E5b clock), for ``NearestToe``: the
    choice ``select_ephemeris`` makes, by bisection (a day at 30 s asks 2,880 x ~90 times over ~7,000
    records)."""
    out: dict[str, list] = {}
    for e in nav:
        if e.system in systems and e.health == 0 and (e.system != "E" or e.data_source & GAL_CLOCK_E1E5B):
            out.setdefault(e.sat_id, []).append(e)
    return {s: NearestToe(v) for s, v in out.items()}


def simulate_station(nav, xyz_m, t0_gpst_s: float, t1_gpst_s: float, interval_s: float = 30.0,
                     signals: dict[str, tuple] | None = None, mask_deg: float = 5.0, seed: int = 0,
                     noise: bool = True):
    """Epochs (t_gpst_s, {sat_id: {code: value}}) of a receiver fixed at ECEF
    ``xyz_m`` from ``t0`` to ``t1`` (GPST s, inclusive) every ``interval_s``,
    from the records of ``nav`` (``read_rinex_nav``: its ``iono['G']``
    Klobuchar set is the ionosphere; ``noise``: False leaves out the code and
    phase noise). Returns (epochs, obs_types)."""
    signals = dict(signals or IGS_SIGNALS)
    rng = np.random.default_rng(seed)
    sats = _by_satellite(nav, set(signals))
    alpha, beta = nav.iono.get("G", (np.zeros(4), np.zeros(4)))
    lat, lon, alt = earth.ecef_to_geodetic(np.asarray(xyz_m, float))
    t = t0_gpst_s + interval_s * np.arange(int(np.floor((t1_gpst_s - t0_gpst_s) / interval_s + 1e-6)) + 1)
    clk_b, clk_d = ClockModel().simulate(t, rng, bias0_m=C_MPS * 1e-4)
    ambiguity: dict[tuple, float] = {}
    epochs = []
    for k, tk in enumerate(t):
        t_true = tk - clk_b[k] / C_MPS           # the epoch is tagged in receiver time (tk), on the interval grid
        ephs = []
        for sid, recs in sats.items():
            e = recs.select(system_time_s(sid[0], t_true))
            if e is not None:
                ephs.append(e)
        r_s, v_s, cb, cd, tau, R, dR = satellite_states_at_reception(ephs, t_true, xyz_m)
        rr = np.einsum("kij,kj->ki", R, r_s)
        vr = np.einsum("kij,kj->ki", R, v_s)
        d = rr - np.asarray(xyz_m, float)
        rho = np.linalg.norm(d, axis=1)
        rate = np.einsum("ki,ki->k", d / rho[:, None], vr)
        el, az = elevation_azimuth(np.asarray(xyz_m, float), rr)
        up = el >= np.deg2rad(mask_deg)
        if not up.any():
            continue
        iono1 = klobuchar_delay_m(alpha, beta, lat, lon, el, az, t_true, F_L1_HZ)
        tropo = hopfield_delay_m(el, alt)[0]
        out = {}
        for j in np.flatnonzero(up):
            e = ephs[j]
            vals = {}
            for code in signals[e.system]:
                try:
                    d_s = group_delay_s(e, code)
                except NoGroupDelay:
                    d_s = 0.0
                f = frequency_hz(e.system, code)
                lam = C_MPS / f
                iono = iono1[j] * (F_L1_HZ / f) ** 2
                geo = rho[j] + clk_b[k] - C_MPS * cb[j] + tropo[j]
                sig = pr_sigma_m(el[j]) * (1.5 if code[0] != "1" else 1.0) * noise
                key = (e.sat_id, code)
                if key not in ambiguity or k and e.sat_id not in epochs[-1][1]:
                    ambiguity[key] = float(rng.integers(-(10 ** 6), 10 ** 6))
                vals["C" + code] = geo + C_MPS * d_s + iono + sig * rng.standard_normal()
                vals["L" + code] = (geo - iono) / lam + ambiguity[key] + 0.002 * noise * rng.standard_normal()
                vals["D" + code] = -(rate[j] + clk_d[k] - C_MPS * cd[j]) / lam
                vals["S" + code] = 30.0 + 20.0 * np.sin(el[j]) - (3.0 if code[0] != "1" else 0.0)
            out[e.sat_id] = vals
        epochs.append((float(tk), out))
    return epochs, obs_types(signals)
