"""Receiver models for real signals: one raw epoch (one channel per signal) ->
one corrected pseudorange and its variance per satellite, shared by
single-point positioning (:mod:`.spp`) and the filter's tightly coupled
update (:mod:`.raw_to_pseudoranges`).

Two steps, so the position-independent work is done once per epoch:

1. :func:`satellite_observations` (no position needed): the signals of each
   satellite by the signal plan (:mod:`.combinations`: ionosphere-free pair
   or single frequency), the broadcast record valid at the epoch (healthy;
   Galileo: the record whose clock refers to the pair used,
   :func:`.signal_delays.galileo_clock_for`), each signal corrected for its
   group delay (:mod:`.signal_delays`) and combined. Satellites are dropped
   and counted when their system is not modelled, their record is missing or
   unhealthy (``unhealthy_<S><prn>`` also names them), or no group delay is
   known for their signals.
2. :func:`corrected_at` (at a receiver position and clock): satellite
   positions at transmit time (light time, :func:`.geometry.satellite_states_at_reception`),
   elevation / azimuth, satellite clock, the broadcast Klobuchar delay for
   single-frequency satellites (IS-GPS-200 20.3.3.5.2.5, scaled by
   (f_L1/f)^2; GPS coefficients also serve Galileo: NeQuick-G is not
   implemented; BDS satellites use the BDS set with the GPS algorithm), the
   Hopfield troposphere (:mod:`.propagation`) and the variance of
   :class:`.weighting.ErrorModel` (or the receiver's own sigmas, ``message``).

    rho_corr = P + c (dt_sv - d_s) - I_klobuchar (single frequency) - T_hopfield
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field, replace

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_gnss.corrections.combinations import DEFAULT_PLAN, choose_signals, iono_free_coefficients, parse_plan
from hyper_nav_gnss.orbits.ephemeris import (
    C_MPS, EphemerisStack, constants, satellite_position_ecef, select_ephemeris, system_time_s,
)
from hyper_nav_gnss.geometry import elevation_azimuth, satellite_states_at_reception
from hyper_nav_gnss.corrections.propagation import F_L1_HZ, hopfield_delay_m, klobuchar_delay_m
from hyper_nav_gnss.corrections.signal_delays import NoGroupDelay, galileo_clock_for, group_delay_s
from hyper_nav_gnss.signals import frequency_hz
from hyper_nav_gnss.corrections.weighting import ErrorModel

MODELLED_SYSTEMS = ("G", "E", "C", "J")


@dataclass(frozen=True)
class ReceiverModel:
    """How real pseudoranges are turned into the filter's / SPP's model input.

    ``plan``: signal plan (parsed, :func:`.combinations.parse_plan`);
    ``errors``: error model, or None to weight with the receiver's own
    pseudorange sigmas (``message``: the simulated receiver's thermal sigma);
    ``klobuchar``: {system: (alpha, beta)} (None: no ionosphere removed);
    ``troposphere``: remove the Hopfield delay; ``elevation_mask_rad``."""
    plan: dict = field(default_factory=lambda: parse_plan(DEFAULT_PLAN))
    errors: ErrorModel | None = field(default_factory=ErrorModel)
    klobuchar: dict | None = None
    troposphere: bool = True
    elevation_mask_rad: float = np.deg2rad(10.0)

    def klobuchar_for(self, system: str):
        """The Klobuchar set for a system's single-frequency signals: its own
        (GPS, BDS, QZSS), else the GPS set (Galileo: NeQuick-G is not
        implemented), else the BDS set (a log too short for GPS subframe 4
        page 18, broadcast every 12.5 min), else None (no correction)."""
        if not self.klobuchar:
            return None
        for key in (system, "G", "C"):
            if key in self.klobuchar:
                return self.klobuchar[key]
        return None


@dataclass(frozen=True)
class SatelliteObservations:
    """Position-independent part of one epoch, per satellite (arrays of n)."""
    t_s: float
    t_rx_gpst_s: float
    choices: tuple
    ephemerides: tuple
    pr_m: np.ndarray              # combined code, group delays removed, satellite clock not yet applied
    dual: np.ndarray              # ionosphere-free pair
    iono_scale: np.ndarray        # (f_L1 / f)^2 of a single-frequency signal (0 for a pair)
    sig_var_m2: np.ndarray        # receiver's own sigmas, combined
    cn0_dbhz: np.ndarray          # (n, 2): per signal (NaN unknown / second signal absent)
    coef: np.ndarray              # (n, 2): a1, a2 of the pair (1, 0 single)

    def __len__(self) -> int:
        return len(self.choices)

    @property
    def sat_ids(self) -> list[str]:
        return [f"{c.system}{c.prn:02d}" for c in self.choices]

    def subset(self, idx) -> "SatelliteObservations":
        idx = np.asarray(idx, int)
        return SatelliteObservations(self.t_s, self.t_rx_gpst_s, tuple(self.choices[k] for k in idx),
                                     tuple(self.ephemerides[k] for k in idx), self.pr_m[idx], self.dual[idx],
                                     self.iono_scale[idx], self.sig_var_m2[idx], self.cn0_dbhz[idx], self.coef[idx])


SELECT_BUCKET_S = 60.0


def _select(store, system, prn, t_gpst_s, clock, counters, received_by_s=np.inf):
    """Healthy record valid at t (EphemerisStore or list of records) among
    those received by ``received_by_s`` (the epoch's stamp: issue 22); counts
    why not. The choice is made at t rounded down to a minute (cached per
    store and set of records received), so it depends on the epoch only, not
    on what was asked before or on the order the records came in."""
    cache = getattr(store, "_select_cache", None)
    n_recv = len(store.records_of(system, prn, received_by_s)) if hasattr(store, "records_of") else -1
    key = (system, int(prn), clock, float(math.floor(t_gpst_s / SELECT_BUCKET_S)), n_recv)
    if cache is not None and key in cache:
        eph, why = cache[key]
        if why:
            counters[why] += 1
            if why == "unhealthy":
                counters[f"unhealthy_{system}{prn:02d}"] += 1
        return eph
    t_gpst_s = key[3] * SELECT_BUCKET_S
    local = Counter()
    eph = _select_now(store, system, prn, t_gpst_s, clock, local, received_by_s)
    why = next((k for k in ("no_ephemeris", "unhealthy", "no_valid_ephemeris") if local[k]), "")
    if cache is not None:
        if len(cache) > 20000:
            cache.clear()
        cache[key] = (eph, why)
    counters.update(local)
    return eph


def _select_now(store, system, prn, t_gpst_s, clock, counters, received_by_s=np.inf):
    if hasattr(store, "records_of"):
        recs = store.records_of(system, prn, received_by_s)
    else:
        recs = [e for e in store if e.system == system and e.prn == prn]
    if not recs:
        counters["no_ephemeris"] += 1
        return None
    t_sys = float(system_time_s(system, t_gpst_s))
    eph = store.choose(recs, t_sys, clock) if hasattr(store, "choose") else \
        select_ephemeris(recs, recs[0].sat_id, t_sys, clock=clock)
    if eph is None:
        if any(e.health != 0 for e in recs) and select_ephemeris(
                [replace(e, health=0) for e in recs], recs[0].sat_id, t_sys) is not None:
            counters["unhealthy"] += 1
            counters[f"unhealthy_{system}{prn:02d}"] += 1
        else:
            counters["no_valid_ephemeris"] += 1
    return eph


_GAL_CLOCK: dict = {}            # galileo_clock_for of a tuple of codes


def satellite_observations(raw, store, model: ReceiverModel, counters: Counter | None = None,
                           exclude=()) -> SatelliteObservations:
    """Step 1 of the module docstring for one RawGnssEpoch. ``store``: an
    EphemerisStore or a list of records; ``exclude``: satellite ids ('G05')
    left out."""
    counters = counters if counters is not None else Counter()
    choices = choose_signals(raw, model.plan, counters)
    keep, ephs, pr, dual, scale, svar, cn0, coef = [], [], [], [], [], [], [], []
    has_cn0 = len(raw.cn0_dbhz) == len(raw.system) and len(raw.system) > 0
    # group delays and pair coefficients of a record and its codes, kept with the store (a record's numbers
    # never change; the record itself is held in the entry, so a reused id() is recognised)
    signal_cache = getattr(store, "_signal_cache", None)
    if signal_cache is None and hasattr(store, "records_of"):
        try:
            store._signal_cache = signal_cache = {}
        except AttributeError:
            signal_cache = None
    if signal_cache is not None and len(signal_cache) > 50000:
        signal_cache.clear()
    # the epoch's channels as Python lists: the same doubles, without a numpy scalar per access
    pr_l = np.asarray(raw.pseudorange_m, float).tolist()
    sg_l = np.asarray(raw.pseudorange_sigma_m, float).tolist()
    cn_l = np.asarray(raw.cn0_dbhz, float).tolist() if has_cn0 else None
    t_rx, t_s = raw.t_rx_gpst_s, raw.t_s
    for ch in choices:
        if ch.system not in MODELLED_SYSTEMS:
            counters["satellites_system_not_modelled"] += 1
            continue
        if exclude and f"{ch.system}{ch.prn:02d}" in exclude:
            counters["satellites_excluded_by_user"] += 1
            continue
        if ch.system == "E":
            clock = _GAL_CLOCK.get(ch.codes)
            if clock is None:
                clock = _GAL_CLOCK[ch.codes] = galileo_clock_for(ch.codes)
        else:
            clock = 0
        eph = _select(store, ch.system, ch.prn, t_rx, clock, counters, t_s)
        if eph is None:
            continue
        key = (id(eph), ch.codes)
        got = signal_cache.get(key) if signal_cache is not None else None
        if got is None or got[0] is not eph:
            try:
                d = [group_delay_s(eph, c) for c in ch.codes]
            except NoGroupDelay:
                counters[f"no_group_delay_{ch.system}{ch.codes[0]}"] += 1
                continue
            if ch.dual:
                a1, a2 = iono_free_coefficients(ch.system, *ch.codes)
                sc = 0.0
            else:
                a1 = a2 = None
                sc = (F_L1_HZ / frequency_hz(ch.system, ch.codes[0])) ** 2
            got = (eph, d, a1, a2, sc)
            if signal_cache is not None:
                signal_cache[key] = got
        _, d, a1, a2, sc = got
        p = [pr_l[k] - C_MPS * dk for k, dk in zip(ch.channels, d)]
        s2 = [sg_l[k] ** 2 for k in ch.channels]
        c0 = [cn_l[k] for k in ch.channels] if has_cn0 else [np.nan] * len(ch.channels)
        if ch.dual:
            pr.append(a1 * p[0] - a2 * p[1])
            svar.append(a1 * a1 * s2[0] + a2 * a2 * s2[1])
            scale.append(0.0)
            cn0.append(c0)
            coef.append((a1, a2))
        else:
            pr.append(p[0])
            svar.append(s2[0])
            scale.append(sc)
            cn0.append((c0[0], np.nan))
            coef.append((1.0, 0.0))
        dual.append(ch.dual)
        ephs.append(eph)
        keep.append(ch)
    counters["satellites_formed"] += len(keep)
    counters["satellites_dual_frequency"] += int(sum(dual))
    return SatelliteObservations(float(raw.t_s), float(raw.t_rx_gpst_s), tuple(keep), tuple(ephs),
                                 np.asarray(pr, float), np.asarray(dual, bool), np.asarray(scale, float),
                                 np.asarray(svar, float), np.asarray(cn0, float).reshape(-1, 2),
                                 np.asarray(coef, float).reshape(-1, 2))


@dataclass(frozen=True)
class SatelliteStates:
    """Satellite positions / velocities at transmit time and clocks, one row per satellite."""
    r_sat_e_m: np.ndarray         # at transmit time, in ECEF(t_tx) (the Sagnac rotation is applied by the users)
    v_sat_e_mps: np.ndarray
    clock_s: np.ndarray           # dt_sv incl. relativity (group delays not applied)
    clock_drift_sps: np.ndarray

    def subset(self, idx) -> "SatelliteStates":
        idx = np.asarray(idx, int)
        return SatelliteStates(self.r_sat_e_m[idx], self.v_sat_e_mps[idx], self.clock_s[idx], self.clock_drift_sps[idx])


def states_from_pseudoranges(obs: SatelliteObservations) -> SatelliteStates:
    """Satellite states at the transmit time t_tx = t_rx - P / c - dt_sv, the
    receiver clock cancelling (RTKLIB manual E.4; ``satposs``): no receiver
    position needed, so single-point positioning evaluates the orbits once
    per epoch. (The filter uses :func:`.geometry.satellite_states_at_reception`
    from its nominal position instead.)"""
    n = len(obs)
    r, v = np.empty((n, 3)), np.empty((n, 3))
    clk, drift = np.empty(n), np.empty(n)
    groups: dict = {}
    for k, e in enumerate(obs.ephemerides):
        groups.setdefault((e.system, e.is_geo), []).append(k)
    for (system, _), idx in groups.items():
        stack = EphemerisStack([obs.ephemerides[k] for k in idx])
        t_sys = np.full(len(idx), float(system_time_s(system, obs.t_rx_gpst_s)))
        tau = obs.pr_m[idx] / C_MPS
        c0 = satellite_position_ecef(stack, t_sys, -tau)[2]
        r[idx], v[idx], clk[idx], drift[idx] = satellite_position_ecef(stack, t_sys, -tau - c0)
    return SatelliteStates(r, v, clk, drift)


@dataclass(frozen=True)
class Corrected:
    """Step 2 of the module docstring at one receiver position (arrays of n)."""
    r_sat_e_m: np.ndarray         # at transmit time, ECEF(t_tx) (the models apply the Sagnac rotation)
    v_sat_e_mps: np.ndarray
    rot: np.ndarray               # (n, 3, 3) R3(we tau): ECEF(t_tx) -> ECEF(t_rx)
    pr_m: np.ndarray              # corrected pseudorange
    var_m2: np.ndarray
    el_rad: np.ndarray
    az_rad: np.ndarray
    iono_m: np.ndarray
    tropo_m: np.ndarray
    sat_clock_s: np.ndarray
    sat_clock_drift_sps: np.ndarray


def _static(obs: SatelliteObservations) -> tuple:
    """Per-satellite numbers of an epoch that no position changes (earth
    rotation rate of each record's system, system letters, record accuracy),
    formed once per epoch and kept on the observations: :func:`corrected_at`
    runs three or more times an epoch."""
    st = obs.__dict__.get("_static")
    if st is None:
        we = np.array([constants(e.system)[1] for e in obs.ephemerides])
        systems = np.array([c.system for c in obs.choices])
        acc = np.array([e.accuracy_m for e in obs.ephemerides])
        st = (we, systems, acc)
        object.__setattr__(obs, "_static", st)
    return st


def _cn0_parts(obs: SatelliteObservations, em: ErrorModel) -> tuple:
    """The C/N0 of each satellite's two signals (the first for the second
    when it has none) and their position-independent variance parts
    (:meth:`.weighting.ErrorModel.cn0_var_m2`), once per epoch."""
    st = obs.__dict__.get("_cn0_parts")
    if st is None:
        c1 = obs.cn0_dbhz[:, 0]
        c2 = np.where(np.isfinite(obs.cn0_dbhz[:, 1]), obs.cn0_dbhz[:, 1], obs.cn0_dbhz[:, 0])
        st = (c1, c2, em.cn0_var_m2(c1), em.cn0_var_m2(c2))
        object.__setattr__(obs, "_cn0_parts", st)
    return st


def _rot_sagnac(obs, r_s, r_a):
    we = _static(obs)[0]
    tau = np.linalg.norm(r_s - r_a, axis=1) / C_MPS
    c, s = np.cos(we * tau), np.sin(we * tau)
    R = np.zeros((len(tau), 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, s, -s, c, 1.0
    return R


def corrected_at(obs: SatelliteObservations, r_rx_e_m, clock_bias_m: float, model: ReceiverModel,
                 states: SatelliteStates | None = None) -> Corrected:
    """Step 2 of the module docstring: corrected pseudoranges at the receiver
    position ``r_rx_e_m`` (ECEF, m) and clock bias ``clock_bias_m`` (sets
    the reception time t_rx - b / c). ``states``: satellite states already
    evaluated (:func:`states_from_pseudoranges`); None = the light-time
    solution from this position (:func:`.geometry.satellite_states_at_reception`)."""
    n = len(obs)
    r_a = np.asarray(r_rx_e_m, float)
    if n == 0:
        z = np.zeros(0)
        return Corrected(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3, 3)), z, z, z, z, z, z, z, z)
    t_rx = obs.t_rx_gpst_s - clock_bias_m / C_MPS
    if states is None:
        r_s, v_s, clk, drift, _, R, _ = satellite_states_at_reception(obs.ephemerides, t_rx, r_a)
    else:
        r_s, v_s, clk, drift = states.r_sat_e_m, states.v_sat_e_mps, states.clock_s, states.clock_drift_sps
        R = _rot_sagnac(obs, r_s, r_a)
    rr = np.einsum("kij,kj->ki", R, r_s)
    near_earth = np.linalg.norm(r_a) > 6.0e6
    if near_earth:
        lat, lon, alt = earth.ecef_to_geodetic(r_a)
        el, az = elevation_azimuth(r_a, rr, (lat, lon, alt))
    else:                                           # first iterations from the Earth's centre: no geometry yet
        el, az = np.full(n, np.pi / 2), np.zeros(n)
        lat = lon = alt = 0.0
    iono = np.zeros(n)
    single = ~obs.dual
    if near_earth and single.any():
        systems = _static(obs)[1]
        for sysc in set(systems[single]):
            ab = model.klobuchar_for(sysc)
            if ab is None:
                continue
            k = np.flatnonzero(single & (systems == sysc))
            iono[k] = klobuchar_delay_m(ab[0], ab[1], lat, lon, np.maximum(el[k], 0.0), az[k], t_rx) * obs.iono_scale[k]
    tropo = hopfield_delay_m(np.maximum(el, 0.0), alt)[0] if (model.troposphere and near_earth) else np.zeros(n)
    pr = obs.pr_m + C_MPS * clk - iono - tropo
    if model.errors is None:
        var = obs.sig_var_m2.copy()
    else:
        em = model.errors
        c1, c2, p1, p2 = _cn0_parts(obs, em)
        v1 = em.receiver_var_m2(el, c1, p1)
        v2 = em.receiver_var_m2(el, c2, p2)
        rx = obs.coef[:, 0] ** 2 * v1 + obs.coef[:, 1] ** 2 * v2
        acc = _static(obs)[2]
        var = rx + em.model_var_m2(el, acc, iono, obs.dual)
    return Corrected(r_s, v_s, R, pr, var, el, az, iono, tropo, clk, drift)
