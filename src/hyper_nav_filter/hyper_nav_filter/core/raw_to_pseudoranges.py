"""Raw receiver epochs + broadcast ephemerides -> corrected pseudoranges for
the tightly coupled update (:class:`~hyper_nav_filter.core.tightly_coupled.Pseudoranges`).

What the receiver does to a raw pseudorange rho_j of satellite j before the
filter's model ``rho_j = |R3(we tau) r_j(t_tx) - r_a| + b`` may use it
(seed 004 eqs. 7, 10, 11; IS-GPS-200 20.3.3.3.3):

    rho_corr = rho + c (dt_sat - TGD) - I_klobuchar - T_hopfield

* only *locked* channels of a supported system ('G', 'C') whose broadcast
  record is known and valid at the epoch (toe within 2 h for GPS, 1 h for
  BDS; :func:`.ephemeris.select_ephemeris`) are used;
* satellite clock dt_sat (polynomial + relativistic term) and group delay
  TGD (GPS L1 C/A; TGD1 for BDS B1I) are added back;
* the broadcast ionosphere (Klobuchar, per-system alpha/beta, scaled to the
  system's carrier) and the Hopfield troposphere (quartic height model) are
  removed, evaluated at the *nominal* antenna position and the satellites'
  elevation/azimuth seen from it;
* satellite position/velocity/clock are evaluated at the transmit time by the
  light-time iteration from the nominal antenna position
  (:func:`.geometry.satellite_states_at_reception`), in ECEF(t_tx): the
  filter's model applies the Sagnac rotation itself. The reception time is
  the receiver's time tag minus the filter's clock-bias estimate. A nominal
  position 300 m off changes the corrected pseudoranges by < 2 mm.

In the fusion engine the correction runs inside the filter
(:class:`RawPseudoranges`, kind "pseudorange"): the channels and their
records are chosen when the epoch arrives, the corrections are computed in
``model()`` at the nominal state of the measurement epoch, so the result does
not depend on the arrival time (live node = offline replay).

Pseudorange rates (``use_rates``): rate_corr = g (rate + c dt_sat_dot), with
g = 1 - u.(d/dt(R3) r_sat - R3 v_sat)/c the light-time rate factor at the
nominal geometry (the simulator's rate contains 1/g, up to 2e-5 relative or
~4 cm/s here; the filter's rate model does not), so that
rate_corr = u.(R3 v_sat - v_a) + d (exact to < 1 mm/s on noise-free
simulated data). Rates are optional (the ``gnss_raw`` source's ``use_rates``, off
by default; the seed004_tight scenario turns them on): on the seed 004
flight (200 s, dynamics-driven lock loss) the solution is 0.66 m RMS with
rates and 1.0 m without, no epoch gated.

Ionosphere coefficients: ``hyper_nav_msgs/GnssMeasurements`` and
``GnssEphemeris`` carry no Klobuchar alpha/beta, so they come from
configuration (the ``gnss_raw`` source's ``klobuchar_alpha`` /
``klobuchar_beta`` parameters, which the scenario fills from its ``gnss.raw``
block, i.e. the set the simulated satellites broadcast).

Systems: one receiver clock bias for all systems (no inter-system bias
state); the simulator has none either.
"""
from __future__ import annotations

import math

from collections import Counter
from dataclasses import dataclass, field, replace

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_filter.core.measurements import Measurement
from hyper_nav_filter.core.params import ConfigError
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_filter.core.tightly_coupled import Pseudoranges
from hyper_nav_gnss.orbits.ephemeris import C_MPS, BroadcastEphemeris
from hyper_nav_gnss.geometry import elevation_azimuth, satellite_states_at_reception
from hyper_nav_gnss.corrections.propagation import (
    CARRIER_HZ, KLOBUCHAR_ALPHA_DEFAULT, KLOBUCHAR_BETA_DEFAULT, hopfield_delay_m, klobuchar_delay_m,
)

from hyper_nav_gnss.observations import SUPPORTED_SYSTEMS, EphemerisStore, RawGnssEpoch, check_raw_epoch


@dataclass(frozen=True)
class ReceiverCorrections:
    """The broadcast delay models the receiver removes. ``klobuchar``:
    {system: (alpha[4], beta[4])} or None (no ionosphere correction);
    ``troposphere``: remove the Hopfield delay."""
    klobuchar: dict | None = field(default_factory=lambda: {
        s: (np.array(KLOBUCHAR_ALPHA_DEFAULT), np.array(KLOBUCHAR_BETA_DEFAULT)) for s in SUPPORTED_SYSTEMS})
    troposphere: bool = True

    @classmethod
    def from_params(cls, ionosphere: str = "klobuchar", alpha=KLOBUCHAR_ALPHA_DEFAULT, beta=KLOBUCHAR_BETA_DEFAULT,
                    troposphere: str = "hopfield") -> "ReceiverCorrections":
        """From node parameters: ionosphere 'klobuchar' | 'off' (alpha, beta:
        4 numbers each, applied to every system), troposphere 'hopfield' | 'off'."""
        if ionosphere not in ("klobuchar", "off"):
            raise ConfigError(f"gnss.ionosphere: expected 'klobuchar' or 'off', got {ionosphere!r}")
        if troposphere not in ("hopfield", "off"):
            raise ConfigError(f"gnss.troposphere: expected 'hopfield' or 'off', got {troposphere!r}")
        ab = []
        for name, v in (("klobuchar_alpha", alpha), ("klobuchar_beta", beta)):
            try:
                a = np.asarray(v, float)
            except (TypeError, ValueError):
                a = np.zeros(0)
            if a.shape != (4,) or not np.all(np.isfinite(a)):
                raise ConfigError(f"gnss.{name}: expected 4 finite numbers, got {v!r}")
            ab.append(a)
        iono = {s: tuple(ab) for s in SUPPORTED_SYSTEMS} if ionosphere == "klobuchar" else None
        return cls(iono, troposphere == "hopfield")


def select_channels(raw: RawGnssEpoch, ephemerides, counters: Counter | None = None):
    """Usable channels of a raw epoch: locked, of a supported system, with a
    broadcast record valid at the epoch. Returns (indices, records);
    ``counters`` (optional) counts channels used / unlocked / without
    ephemeris / of unsupported systems. ``ephemerides``: an
    :class:`EphemerisStore` or a mapping {(system, prn): record or records}."""
    store = ephemerides if isinstance(ephemerides, EphemerisStore) else EphemerisStore.from_mapping(ephemerides)
    counters = counters if counters is not None else Counter()
    idx, ephs = [], []
    for k, (sys_k, prn_k, locked_k) in enumerate(zip(raw.system, raw.prn, raw.locked)):
        if not locked_k:
            counters["channels_unlocked"] += 1
        elif sys_k not in SUPPORTED_SYSTEMS:
            counters["channels_unsupported_system"] += 1
        else:
            eph = store.select(sys_k, int(prn_k), raw.t_rx_gpst_s, raw.t_s)      # records received by the epoch
            if eph is None:
                counters["channels_no_ephemeris"] += 1
            else:
                idx.append(k)
                ephs.append(eph)
    counters["channels_used"] += len(idx)
    return np.asarray(idx, int), tuple(ephs)


def corrected_pseudoranges(raw: RawGnssEpoch, channels, ephs, r_ant_e_m, corrections: ReceiverCorrections,
                           rx_clock_bias_m: float = 0.0, use_rates: bool = False) -> Pseudoranges:
    """Pseudoranges of the ``channels`` of ``raw`` (records ``ephs``) corrected
    at the nominal antenna position ``r_ant_e_m`` (ECEF, m) and receiver clock
    bias ``rx_clock_bias_m`` (sets the reception time), see the module docstring."""
    idx = np.asarray(channels, int)
    t_rx = raw.t_rx_gpst_s - rx_clock_bias_m / C_MPS
    r_a = np.asarray(r_ant_e_m, float)
    r_s, v_s, clk_s, drift_s, _, R, dR = satellite_states_at_reception(ephs, t_rx, r_a)
    rr = np.einsum("kij,kj->ki", R, r_s)                        # satellites in ECEF(t)
    el, az = elevation_azimuth(r_a, rr)
    el = np.maximum(el, 0.0)
    lat, lon, alt = earth.ecef_to_geodetic(r_a)
    iono = np.zeros(len(ephs))
    if corrections.klobuchar is not None:
        for k, e in enumerate(ephs):
            if e.system in corrections.klobuchar:
                alpha, beta = corrections.klobuchar[e.system]
                iono[k] = klobuchar_delay_m(alpha, beta, lat, lon, el[k], az[k], t_rx, CARRIER_HZ[e.system])
    tropo = hopfield_delay_m(el, alt)[0] if corrections.troposphere else np.zeros(len(ephs))
    tgd = np.array([e.tgd for e in ephs])
    pr = np.asarray(raw.pseudorange_m, float)[idx] + C_MPS * (clk_s - tgd) - iono - tropo
    pr_var = np.asarray(raw.pseudorange_sigma_m, float)[idx] ** 2
    rate = rate_var = np.zeros(0)
    if use_rates:
        d = rr - r_a
        u = d / np.linalg.norm(d, axis=1)[:, None]
        g = 1.0 - np.einsum("ki,ki->k", u, np.einsum("kij,kj->ki", dR, r_s) - np.einsum("kij,kj->ki", R, v_s)) / C_MPS
        rate = g * (np.asarray(raw.rate_mps, float)[idx] + C_MPS * drift_s)
        rate_var = np.asarray(raw.rate_sigma_mps, float)[idx] ** 2
    return Pseudoranges(float(raw.t_s), r_s, v_s, pr, pr_var, rate, rate_var)


def raw_to_pseudoranges(raw: RawGnssEpoch, ephemerides, r_ant_e_m, corrections: ReceiverCorrections | None = None,
                        rx_clock_bias_m: float = 0.0, use_rates: bool = False,
                        counters: Counter | None = None) -> Pseudoranges | None:
    """Corrected pseudoranges (and rates) of one raw epoch, see the module
    docstring: :func:`select_channels` then :func:`corrected_pseudoranges`.
    ``ephemerides``: an :class:`EphemerisStore` or a mapping
    {(system, prn): record or list of records}; ``r_ant_e_m``: nominal
    antenna position (ECEF, m) at the epoch; ``rx_clock_bias_m``: the
    filter's receiver clock-bias estimate. Returns None when no channel is
    usable. Raises MalformedGnssInput for a malformed epoch."""
    check_raw_epoch(raw)
    idx, ephs = select_channels(raw, ephemerides, counters)
    if not len(idx):
        return None
    return corrected_pseudoranges(raw, idx, ephs, r_ant_e_m, corrections if corrections is not None
                                  else ReceiverCorrections(), rx_clock_bias_m, use_rates)


def nominal_receiver(state: NavState, lever_arm_b_m, t_s: float) -> tuple[np.ndarray, float]:
    """Nominal antenna ECEF position [m] and receiver clock bias [m] at epoch
    t_s, from a filter state (extrapolated with its velocity and clock drift
    from state.t_s; the lever arm l_b is body FLU)."""
    dt = t_s - state.t_s
    C_n_e = earth.C_n_e(state.lat_rad, state.lon_rad)
    r = earth.geodetic_to_ecef(state.lat_rad, state.lon_rad, state.alt_m) + C_n_e @ (
        state.C_b_n @ np.asarray(lever_arm_b_m, float) + state.vel_enu_mps * dt)
    clk = state.extra.get("clk")
    return r, (0.0 if clk is None else float(clk[0] + clk[1] * dt))


class RangeBiasSlots:
    """Which satellite holds which slot of the range-bias block
    (``blocks.range_bias``). A satellite keeps its slot while it is used and
    after it is lost, with its bias state propagated by the block's
    Gauss-Markov model (the estimate decays towards 0 and its variance
    grows towards sigma^2 with tau): a satellite back after a loss of lock,
    even a long one (a plasma blackout), finds its own bias state, which is
    what the model says it knows of it; resetting it would throw away what
    the epochs before the loss said about a range error correlated over tau
    (measured on the seed 004 blackout: the returning satellites' reset
    slots let their range errors into the position, NEES 4.3 after it
    against 2.7 with the slots kept, issue 23). A newly used satellite takes
    the lowest free slot, or else the slot of the satellite unseen longest
    among those unseen for more than ``release_s``; the slot is reset (its
    row and column of P zeroed, variance sigma^2, value 0). When no slot can
    be had the satellite gets none (its measurement variance takes the bias
    variance instead; counted). Assignment follows the epochs in the order
    they are processed (epoch order: ``TightGnssInput.ready``)."""

    def __init__(self, n_slots: int, release_s: float = 30.0):
        self.n = int(n_slots)
        self.release_s = float(release_s)
        self.owner: list = [None] * self.n
        self.slot_of: dict = {}
        self.last_seen: dict = {}

    def _take(self, now: set, t_s: float) -> int:
        """A slot for a newly used satellite: the lowest free one, else the one
        whose satellite has been unseen longest, if longer than release_s; -1: none."""
        for k in range(self.n):
            if self.owner[k] is None:
                return k
        idle = [(self.last_seen[sat], k) for k, sat in enumerate(self.owner)
                if sat not in now and t_s - self.last_seen[sat] > self.release_s]
        if not idle:
            return -1
        _, k = min(idle)
        del self.slot_of[self.owner[k]]
        return k

    def assign(self, sat_ids, t_s: float, counters: Counter | None = None):
        """(slot per satellite, -1 = none; slots to reset)."""
        now = set(sat_ids)
        slots, resets = [], []
        for sat in sat_ids:
            s = self.slot_of.get(sat, -1)
            if s < 0:
                s = self._take(now, t_s)
                if s >= 0:
                    if self.owner[s] is not None and counters is not None:
                        counters["range_bias_slot_taken_over"] += 1
                    self.owner[s] = sat
                    self.slot_of[sat] = s
                    resets.append(s)
                elif counters is not None:
                    counters["range_bias_pool_full"] += 1
            self.last_seen[sat] = t_s
            slots.append(s)
        return np.asarray(slots, int), resets


def shared_range_bias_slots(engine, n_slots: int, release_s: float) -> RangeBiasSlots:
    """The one slot pool of an engine's range-bias block, shared by every
    source feeding it (two pools over one block would hand the same slot to
    two satellites and reset each other's states: seen with the real and the
    virtual pseudorange sources of seed 004); created by the first source
    that feeds the engine, with its ``release_s``. The sources keep their
    satellites apart by name (``TightGnssInput.slot_owner``)."""
    pool = getattr(engine, "range_bias_slots", None)
    if pool is None:
        pool = RangeBiasSlots(n_slots, release_s)
        engine.range_bias_slots = pool
    return pool


def _isb_cols(systems) -> np.ndarray:
    from hyper_nav_filter.core.blocks.range_bias import InterSystemBias
    order = InterSystemBias.SYSTEMS
    return np.array([order.index(s) if s in order else -1 for s in systems], int)


@dataclass(frozen=True)
class RawPseudoranges(Measurement):
    """Measurement of the fusion engine (kind "pseudorange"): a raw epoch with
    its usable channels and their broadcast records, corrected inside the
    filter at the nominal state *of its epoch* (:meth:`model` builds the
    :class:`Pseudoranges` there). The result does not depend on when the
    message arrived (a late epoch is re-processed from its own state), so the
    live node and an offline run over the bag agree.

    Two receiver models: the simulated receiver's channels (``channels``,
    ``ephemerides``, ``corrections``: this module's functions), or real
    signals (``receiver`` + ``observations``: :mod:`.receiver_model`, signal
    plan, group delays, ionosphere-free pairs, the error model's variances,
    elevation mask at the nominal position). ``isb_col`` / ``bias_slot``:
    inter-system-bias column and range-bias slot per satellite
    (``blocks.range_bias``); ``state_resets`` the slots taken anew
    (``ErrorStateKF.apply_resets``); ``unslotted_var_m2`` the bias variance
    added to satellites without a slot. ``epoch``: for one satellite of a
    per-satellite epoch, (the epoch's observations, their states, this
    satellite's row): the corrections (satellite clock, ionosphere,
    troposphere, weights, elevation mask) are then computed for all the
    epoch's satellites once per pass over the epoch, at the nominal state
    of the first satellite's update (``ModelContext.cache``), instead of
    once per satellite: the state moves by centimetres between the
    satellites' updates, which changes these corrections by micrometres.
    Measured on the walk_0827 log (14.6 satellites per epoch): the
    correction step took 4.2 s of a 14 s profiled replay, 0.6 s after."""
    t_s: float
    raw: RawGnssEpoch
    channels: np.ndarray
    ephemerides: tuple
    corrections: ReceiverCorrections
    use_rates: bool = False
    kind: str = "pseudorange"
    receiver: object = None
    observations: object = None
    states: object = None
    isb_col: np.ndarray | None = None
    bias_slot: np.ndarray | None = None
    bias_block: str = ""
    state_resets: tuple = ()
    unslotted_var_m2: float = 0.0
    epoch: tuple | None = None
    coupling = "tight"

    @property
    def sat_ids(self) -> list[str]:
        if self.observations is not None:
            return self.observations.sat_ids
        return [f"{self.raw.system[k]}{int(self.raw.prn[k]):02d}" for k in self.channels]

    def pseudoranges(self, state: NavState, lever_arm_b_m, cache: dict | None = None) -> Pseudoranges:
        r_ant, clk = nominal_receiver(state, lever_arm_b_m, self.t_s)
        if self.epoch is not None and cache is not None:
            obs_all, states_all, row = self.epoch
            key = ("pseudoranges", id(obs_all))
            hit = cache.get(key)
            if hit is None:
                p_all, keep_all = _real_pseudoranges(obs_all, self.raw, r_ant, clk, self.receiver, self.use_rates,
                                                     states_all)
                hit = cache[key] = (p_all, {int(k): j for j, k in enumerate(keep_all)})
            p_all, where = hit
            j = where.get(row)
            keep = np.zeros(1 if j is not None else 0, int)
            sl = slice(j, j + 1) if j is not None else slice(0, 0)
            p = Pseudoranges(p_all.t_s, p_all.sat_pos_e_m[sl], p_all.sat_vel_e_mps[sl], p_all.pseudorange_m[sl],
                             p_all.pseudorange_var_m2[sl], p_all.rate_mps[sl] if len(p_all.rate_mps) else p_all.rate_mps,
                             p_all.rate_var_m2ps2[sl] if len(p_all.rate_var_m2ps2) else p_all.rate_var_m2ps2)
        elif self.observations is None:
            p = corrected_pseudoranges(self.raw, self.channels, self.ephemerides, r_ant, self.corrections, clk,
                                       self.use_rates)
            keep = None
        else:
            p, keep = _real_pseudoranges(self.observations, self.raw, r_ant, clk, self.receiver, self.use_rates,
                                         self.states)
        isb, slot = self.isb_col, self.bias_slot
        if keep is not None:
            isb = None if isb is None else isb[keep]
            slot = None if slot is None else slot[keep]
        if slot is not None and self.unslotted_var_m2 > 0.0 and np.any(slot < 0):
            p = replace(p, pseudorange_var_m2=p.pseudorange_var_m2 + np.where(slot < 0, self.unslotted_var_m2, 0.0))
        return replace(p, isb_col=isb, bias_slot=slot, bias_block=self.bias_block)

    def model(self, state: NavState, layout, ctx):
        return self.pseudoranges(state, ctx.lever_arm_b_m, getattr(ctx, "cache", None)).model(state, layout, ctx)


def _real_pseudoranges(obs, raw, r_ant, clk, receiver, use_rates, states=None):
    """Pseudoranges of real signals at the nominal receiver (receiver_model;
    satellite states at the transmit time given by the pseudoranges,
    ``receiver_model.states_from_pseudoranges``, evaluated once when the
    measurement is made: they do not depend on the receiver position);
    satellites below the elevation mask left out. Rates: the first signal's, + c x satellite clock drift (the
    light-time rate factor, 2e-5 relative, is left out: real receivers here
    move at walking speed)."""
    from hyper_nav_gnss.corrections.receiver_model import corrected_at
    cor = corrected_at(obs, r_ant, clk, receiver, states)
    keep = np.flatnonzero(cor.el_rad >= receiver.elevation_mask_rad)
    rate = rate_var = np.zeros(0)
    if use_rates:
        ch0 = np.array([c.channels[0] for c in obs.choices], int)
        rate = (np.asarray(raw.rate_mps, float)[ch0] + C_MPS * cor.sat_clock_drift_sps)[keep]
        rate_var = (np.asarray(raw.rate_sigma_mps, float)[ch0] ** 2)[keep]
        ok = np.isfinite(rate)
        rate = np.where(ok, rate, 0.0)
        rate_var = np.where(ok, rate_var, 1e12)             # no Doppler: no information
    return Pseudoranges(float(raw.t_s), cor.r_sat_e_m[keep], cor.v_sat_e_mps[keep], cor.pr_m[keep],
                        cor.var_m2[keep], rate, rate_var), keep


class TightGnssInput:
    """The tightly coupled GNSS input of a fusion engine: ephemeris store and
    raw epochs waiting for their ephemerides.

    Ephemerides and raw epochs arrive on different topics, so a raw epoch may
    come before the record it needs (at start-up, or when a new set is
    broadcast). A raw epoch is held until every locked channel of a supported
    system has a record, or until the filter time passes its epoch by
    ``hold_s`` (then the channels without one are dropped). Keep ``hold_s``
    below the engine's ``output_delay_s`` so that released solutions do not
    depend on the arrival order. A satellite still without a record when
    its epoch's hold ran out is not waited for again for ``absent_retry_s``
    (filter time): a tracked satellite whose ephemeris is never broadcast
    or never decoded (walk_0827: G18 and C50 for the whole log) would
    otherwise hold every epoch for ``hold_s`` and make every measurement
    late, re-processing ``hold_s`` of IMU epochs each time (measured on the
    walk: 37118 re-processed epochs for 18549 IMU samples, 2x the work).

    ``receiver``: a :class:`.receiver_model.ReceiverModel` for real signals
    (None: the simulated receiver's channels); ``per_satellite``: one
    measurement per satellite, so the filter's chi-square innovation gate
    tests and rejects satellites one by one (fault detection and exclusion
    in the filter) instead of whole epochs; ``range_bias_release_s``: see
    :class:`RangeBiasSlots` (used when the engine's layout has ``rb`` or
    ``rb32``)."""

    def __init__(self, corrections: ReceiverCorrections | None = None, use_rates: bool = False,
                 hold_s: float = 0.5, receiver=None, per_satellite: bool = False,
                 range_bias_release_s: float = 30.0, absent_retry_s: float = 30.0, slot_owner: str = ""):
        self.corrections = corrections if corrections is not None else ReceiverCorrections()
        self.slot_owner = str(slot_owner)          # prefix of its satellites' names in the range-bias pool
        self.absent_retry_s = float(absent_retry_s)
        self._absent: dict[tuple, float] = {}      # (system, prn) -> epoch whose hold ran out without its record
        self._version = 0                          # bumped when a record comes or a satellite is given up
        self._incomplete_at: dict[int, int] = {}   # id(pending epoch) -> version it was found incomplete at
        self.use_rates = bool(use_rates)
        self.hold_s = float(hold_s)
        self.receiver = receiver
        self.per_satellite = bool(per_satellite)
        self.range_bias_release_s = float(range_bias_release_s)
        self.ephemerides = EphemerisStore()
        self.counters: Counter = Counter()
        self._pending: list[RawGnssEpoch] = []
        self._slots: RangeBiasSlots | None = None

    def add_ephemeris(self, eph: BroadcastEphemeris, received_s: float = -math.inf) -> None:
        """Store a record received at ``received_s`` (its message's stamp);
        raises MalformedGnssInput for an invalid one."""
        self.ephemerides.add(eph, received_s)
        self._version += 1

    def add_klobuchar(self, system: str, alpha, beta) -> None:
        """A broadcast Klobuchar set (GnssEphemeris.klobuchar_*) for the real-signal model."""
        if self.receiver is not None:
            kb = dict(self.receiver.klobuchar or {})
            kb[system] = (np.asarray(alpha, float), np.asarray(beta, float))
            self.receiver = replace(self.receiver, klobuchar=kb)

    def add_raw(self, raw: RawGnssEpoch) -> None:
        """Queue a raw epoch; raises MalformedGnssInput for a malformed one."""
        check_raw_epoch(raw)
        self._pending.append(raw)

    def _complete(self, raw: RawGnssEpoch) -> bool:
        t = raw.t_rx_gpst_s
        return not self._missing(raw, waited_for=True)

    def _missing(self, raw: RawGnssEpoch, waited_for: bool) -> list[tuple]:
        """Locked channels of a supported system without an ephemeris record at
        the epoch, as (system, prn); with ``waited_for`` only those still worth
        waiting for (not given up within ``absent_retry_s`` before the epoch)."""
        t = raw.t_rx_gpst_s
        systems = SUPPORTED_SYSTEMS if self.receiver is None else tuple(self.receiver.plan)
        out = []
        for s, p, ok in zip(raw.system, raw.prn, raw.locked):
            if not ok or s not in systems:
                continue
            if waited_for and raw.t_s - self._absent.get((s, int(p)), -math.inf) < self.absent_retry_s:
                continue
            if self.ephemerides.select(s, p, t, raw.t_s) is None:
                out.append((s, int(p)))
                if waited_for:
                    break
        return out

    def ready(self, t_now_s: float) -> list[RawGnssEpoch]:
        """Pending epochs to process now (complete ones, and those held past
        hold_s at filter time t_now_s), in epoch order. The satellites an
        epoch held past hold_s still lacks are given up for absent_retry_s."""
        out = []
        for r in self._pending:
            # an epoch found incomplete stays so until a record comes or a satellite is given up (_version)
            if self._incomplete_at.get(id(r)) != self._version and self._complete(r):
                out.append(r)
            elif r.t_s <= t_now_s - self.hold_s:
                out.append(r)
                for key in self._missing(r, waited_for=False):
                    self._absent[key] = float(r.t_s)
                    self._version += 1
                self.counters["epochs_held_out"] += 1
            else:
                self._incomplete_at[id(r)] = self._version
        for r in out:
            self._incomplete_at.pop(id(r), None)
        if out:
            self._pending = [r for r in self._pending if not any(r is o for o in out)]
        return sorted(out, key=lambda r: r.t_s)

    def measurement(self, raw: RawGnssEpoch, cfg=None) -> RawPseudoranges | None:
        """The engine measurement of a ready epoch (None: no usable channel);
        with ``per_satellite``, the first of :meth:`measurements`."""
        m = self.measurements(raw, cfg)
        return m[0] if m else None

    def measurements(self, raw: RawGnssEpoch, cfg=None) -> list:
        """The engine measurements of a ready epoch: one RawPseudoranges, or
        one per satellite (``per_satellite``); empty when no channel is usable.
        ``cfg``: the engine's FilterConfig (its layout says whether there
        are range-bias and inter-system-bias states)."""
        states = None
        if self.receiver is None:
            idx, ephs = select_channels(raw, self.ephemerides, self.counters)
            obs = None
            n = len(idx)
            systems = [raw.system[k] for k in idx]
        else:
            from hyper_nav_gnss.corrections.receiver_model import satellite_observations, states_from_pseudoranges
            obs = satellite_observations(raw, self.ephemerides, self.receiver, self.counters)
            idx, ephs = np.zeros(0, int), ()
            n = len(obs)
            states = states_from_pseudoranges(obs) if n else None
            systems = [c.system for c in obs.choices]
        if not n:
            self.counters["epochs_without_usable_channel"] += 1
            return []
        lay = cfg.layout if cfg is not None else None
        isb = _isb_cols(systems) if (lay is not None and lay.has("isb")) else None
        block = next((b for b in ("rb", "rb32") if lay is not None and lay.has(b)), "")
        slots, resets, var_b = None, (), 0.0
        if block:
            from hyper_nav_filter.core.blocks import REGISTRY
            if self._slots is None:
                self._slots = RangeBiasSlots(REGISTRY[block].size, self.range_bias_release_s)
            sat_ids = [f"{self.slot_owner}{s}{int(p):02d}" for s, p in zip(systems, (raw.prn[k] for k in idx) if obs is None
                                                        else (c.prn for c in obs.choices))]
            slots, new = self._slots.assign(sat_ids, float(raw.t_s), self.counters)
            sigma = float(cfg.range_bias_sigma_m)
            resets = tuple((block, int(s), sigma) for s in new)
            var_b = sigma ** 2
            self.counters["range_bias_slot_resets"] += len(new)
        common = dict(use_rates=self.use_rates, receiver=self.receiver, bias_block=block, unslotted_var_m2=var_b)
        if not self.per_satellite:
            return [RawPseudoranges(float(raw.t_s), raw, idx, ephs, self.corrections, observations=obs, states=states,
                                    isb_col=isb, bias_slot=slots, state_resets=resets, **common)]
        out = []
        for k in range(n):
            sl = [k]
            res_k = tuple(r for r in resets if slots is not None and r[1] == slots[k])
            out.append(RawPseudoranges(
                float(raw.t_s), raw, idx[sl] if obs is None else idx, tuple(ephs[j] for j in sl) if obs is None else (),
                self.corrections, observations=None if obs is None else obs.subset(sl),
                states=None if states is None else states.subset(sl),
                isb_col=None if isb is None else isb[sl], bias_slot=None if slots is None else slots[sl],
                state_resets=res_k, epoch=None if obs is None else (obs, states, k), **common))
        return out

    def feed(self, engine) -> int:
        """Queue the measurements of the ready epochs (at the engine's filter
        time) in ``engine`` (a FusionEngine). Returns how many were added."""
        n = 0
        cfg = getattr(engine, "cfg", None)
        if self._slots is None and cfg is not None:
            block = next((b for b in ("rb", "rb32") if cfg.layout.has(b)), "")
            if block:
                from hyper_nav_filter.core.blocks import REGISTRY
                self._slots = shared_range_bias_slots(engine, REGISTRY[block].size, self.range_bias_release_s)
        for raw in self.ready(engine.t_latest_s):
            # a stale epoch (before the filter's start, or behind its window) is refused by the engine and
            # counted there; it must not take range-bias slots either, or the solution would depend on how
            # many such epochs a run received (a live node may get fewer of them than the bag holds;
            # measured on the walk: 52 pre-start epochs moved velocities by 2e-13 m/s, live != offline)
            for m in self.measurements(raw, None if engine.is_stale(float(raw.t_s)) else cfg):
                ok, _ = engine.add_measurement(m)
                n += int(ok)
        return n
