"""Single-point positioning (SPP) from real pseudoranges, with RAIM/FDE.

Per epoch, weighted least squares (Gauss-Newton from the previous solution or
the Earth's centre; RTKLIB manual E.6.1, Kaplan & Hegarty 2nd ed. 2.4.2):

    rho_corr_j = |R3(we tau_j) r_j - r| + b + b_sys(j) + e_j,   e_j ~ N(0, sigma_j^2)

with rho_corr from :mod:`.receiver_model` (signal plan, group delays,
ionosphere-free pair or Klobuchar, Hopfield, satellite clock; the error
model's variance as weight), r the antenna position (ECEF), b the receiver
clock bias of the reference system (the first of G, E, C, J present) and
b_sys the inter-system bias of each other system with satellites at the
epoch (one unknown per system: per-epoch equivalent to per-system clocks).
Satellites below the elevation mask are left out once the position is
known. Fault detection and exclusion: :mod:`.raim` (global chi-square test
at the false-alarm probability ``p_fa``, exclusion of the largest
standardized residual, repeated while a degree of freedom remains).

Outputs per epoch (:class:`SppSolution`): position, covariance, clock and
inter-system biases, DOPs (geometry only, ENU at the solution), residuals
and weights of every satellite, the excluded ones with their w-test, the
test statistic and its threshold, and a status.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_gnss.positioning.dop import dops
from hyper_nav_gnss.positioning import least_squares as lsq
from hyper_nav_gnss.positioning.raim import global_statistic, standardized_residuals, threshold
from hyper_nav_gnss.corrections.receiver_model import (
    ReceiverModel, _static, corrected_at, satellite_observations, states_from_pseudoranges,
)

from hyper_nav_gnss.constants import C_MPS
from hyper_nav_gnss.corrections.propagation import hopfield_delay_m, klobuchar_delay_m

SYSTEM_ORDER = ("G", "E", "C", "J")
BATCH_EPOCHS = 600              # epochs whose satellite orbits are evaluated together (:func:`states_batch`)


@dataclass(frozen=True)
class SppConfig:
    """``p_fa``: false-alarm probability of the global test (1e-3: one epoch
    in a thousand flagged when nothing is wrong); ``max_exclusions`` per
    epoch; ``max_iterations`` and ``tol_m`` of Gauss-Newton;
    ``warm_tol_m``: from a start near the antenna (the previous epoch, a
    header position) the second step ends the iterations when it is shorter
    than this (Gauss-Newton converges quadratically there: the solution is
    then within 1e-6 m of the fully converged one on TLSE, tested; one
    corrected-pseudorange evaluation an epoch saved)."""
    model: ReceiverModel = field(default_factory=ReceiverModel)
    p_fa: float = 1e-3
    max_exclusions: int = 4
    max_iterations: int = 12
    tol_m: float = 1e-4
    warm_tol_m: float = 1e-3
    exclude: tuple = ()


@dataclass
class SppSolution:
    t_s: float
    t_rx_gpst_s: float
    status: str                         # ok | fault_excluded | fault_not_excluded | no_test | too_few_satellites
    pos_ecef_m: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    cov_ecef_m2: np.ndarray = field(default_factory=lambda: np.full((3, 3), np.nan))
    clock_bias_m: float = np.nan
    reference_system: str = ""
    isb_m: dict = field(default_factory=dict)
    dop: dict = field(default_factory=dict)
    sat_ids: list = field(default_factory=list)
    residual_m: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sigma_m: np.ndarray = field(default_factory=lambda: np.zeros(0))
    el_rad: np.ndarray = field(default_factory=lambda: np.zeros(0))
    az_rad: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cn0_dbhz: np.ndarray = field(default_factory=lambda: np.zeros(0))
    dual: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    used: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    excluded: list = field(default_factory=list)      # [(sat_id, w-test, T before exclusion)]
    below_mask: list = field(default_factory=list)
    test_statistic: float = np.nan
    test_threshold: float = np.nan
    dof: int = 0
    iterations: int = 0

    @property
    def valid(self) -> bool:
        return self.status in ("ok", "fault_excluded", "no_test")

    @property
    def n_used(self) -> int:
        return int(np.count_nonzero(self.used))


def _least_squares(obs, states, x0, systems_all, cfg: SppConfig, use_mask: bool):
    """Gauss-Newton over the satellites of ``obs``; returns (x, cor, H, v, var,
    mask_ok, iterations, systems) or None when singular."""
    model = cfg.model
    r = np.array(x0[:3], float)
    b = float(x0[3]) if len(x0) > 3 else 0.0
    ok = np.ones(len(obs), bool)
    it = 0
    x = None
    warm = use_mask and np.linalg.norm(r) > 6.0e6          # started from a position near the antenna
    sys_all = _static(obs)[1]
    for it in range(1, cfg.max_iterations + 1):
        cor = corrected_at(obs, r, b, model, states)
        if use_mask and np.linalg.norm(r) > 6.0e6:
            ok = cor.el_rad >= model.elevation_mask_rad
        idx = np.flatnonzero(ok)
        sys_of = sys_all[idx]
        systems = [s for s in systems_all if (sys_of == s).any()]
        m = 3 + len(systems)
        if len(idx) < m:
            return None
        rs = np.einsum("kij,kj->ki", cor.rot[idx], cor.r_sat_e_m[idx])
        d = r - rs
        rho = np.linalg.norm(d, axis=1)
        u = d / rho[:, None]
        H = np.hstack([u, lsq.clock_columns(sys_of, systems)])   # reference clock on every row, ISB columns
        if x is None or len(x) != m:
            x = np.concatenate([r, [b], np.zeros(m - 4)])
        pred = rho + H[:, 3:] @ x[3:]
        v = cor.pr_m[idx] - pred
        step = lsq.solve_step(H, v, 1.0 / cor.var_m2[idx])
        if step is None:
            return None
        dx = step[0]
        x = x + dx
        r, b = x[:3], x[3]
        step = float(np.linalg.norm(dx[:3]))
        if it > 1 and (step < cfg.tol_m or (warm and step < cfg.warm_tol_m)):
            break
    cor = corrected_at(obs, r, b, model, states)
    rs = np.einsum("kij,kj->ki", cor.rot[idx], cor.r_sat_e_m[idx])
    d = r - rs
    rho = np.linalg.norm(d, axis=1)
    v = cor.pr_m[idx] - (rho + H[:, 3:] @ x[3:])
    return x, cor, H, v, cor.var_m2[idx], idx, it, systems


def states_batch(obs_list) -> list:
    """:func:`.receiver_model.states_from_pseudoranges` of many epochs at
    once: the records of every epoch's satellites stacked per system and
    orbit kind, each stack evaluated in one call (the same formulas, element
    by element: equal to the per-epoch evaluation, tested), then split back
    per epoch. Per-epoch evaluation was 8 small-array calls an epoch, 23 % of
    the solve time in the profile."""
    from hyper_nav_gnss.orbits.ephemeris import satellite_position_ecef, system_time_s
    from hyper_nav_gnss.corrections.receiver_model import SatelliteStates
    sizes = [len(o) for o in obs_list]
    off = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
    flat_ephs = [e for o in obs_list for e in o.ephemerides]
    n = len(flat_ephs)
    flat_pr = np.concatenate([o.pr_m for o in obs_list]) if n else np.zeros(0)
    flat_ep = np.repeat(np.arange(len(obs_list)), sizes)
    rows: dict = {}
    for i, e in enumerate(flat_ephs):
        rows.setdefault((e.system, e.is_geo), []).append(i)
    R, V, C, D = np.empty((n, 3)), np.empty((n, 3)), np.empty(n), np.empty(n)
    for (system, _), ii in rows.items():
        ii = np.asarray(ii, int)
        stack = _stack_rows([flat_ephs[i] for i in ii])
        t_ep = np.array([float(system_time_s(system, o.t_rx_gpst_s)) for o in obs_list])
        t_sys = t_ep[flat_ep[ii]]
        tau = flat_pr[ii] / C_MPS
        c0 = satellite_position_ecef(stack, t_sys, -tau)[2]
        R[ii], V[ii], C[ii], D[ii] = satellite_position_ecef(stack, t_sys, -tau - c0)
    return [SatelliteStates(R[a:b], V[a:b], C[a:b], D[a:b]) for a, b in zip(off[:-1], off[1:])]


def _stack_rows(ephs):
    """``EphemerisStack(ephs)`` built from the distinct records only (a record
    serves a satellite for every epoch of its validity: ~30x fewer), its
    arrays then indexed per row: the same numbers."""
    from hyper_nav_gnss.orbits.ephemeris import _STACKED_FIELDS, EphemerisStack
    uniq: dict = {}
    idx = np.array([uniq.setdefault(id(e), (len(uniq), e))[0] for e in ephs], int)
    base = EphemerisStack([e for _, e in uniq.values()])
    st = object.__new__(EphemerisStack)
    st.system, st.is_geo = base.system, base.is_geo
    for name in _STACKED_FIELDS + ("toe_s", "toc_s"):
        setattr(st, name, getattr(base, name)[idx])
    return st


def solve_epoch(raw, store, cfg: SppConfig, x0=None, counters: Counter | None = None,
                obs=None, states=None) -> SppSolution:
    """SPP of one RawGnssEpoch with RAIM/FDE (module docstring). ``store``:
    EphemerisStore or list of records; ``x0``: initial [x, y, z, b] (e.g.
    the previous solution; None = the Earth's centre); ``obs`` / ``states``:
    the epoch's satellite observations and states already formed (:func:`solve`)."""
    counters = counters if counters is not None else Counter()
    if obs is None:
        obs = satellite_observations(raw, store, cfg.model, counters, exclude=cfg.exclude)
    sol = SppSolution(float(raw.t_s), float(raw.t_rx_gpst_s), "too_few_satellites")
    systems_all = [s for s in SYSTEM_ORDER if any(c.system == s for c in obs.choices)]
    if len(obs) < 4:
        counters["epochs_too_few_satellites"] += 1
        return sol
    if states is None:
        states = states_from_pseudoranges(obs)
    start = np.zeros(4) if x0 is None or not np.all(np.isfinite(x0)) else np.asarray(x0, float)[:4]
    res = None
    if x0 is None or not np.all(np.isfinite(x0)):
        res = _least_squares(obs, states, start, systems_all, cfg, use_mask=False)   # from the centre first
        if res is not None:
            start = np.concatenate([res[0][:4]])
    res = _least_squares(obs, states, start, systems_all, cfg, use_mask=True)
    if res is None:
        counters["epochs_too_few_satellites"] += 1
        return sol
    active = np.ones(len(obs), bool)
    excluded = []
    x, cor, H, v, var, idx, it, systems = res
    in_fit, sat_ids = set(idx.tolist()), obs.sat_ids
    below = [sat_ids[k] for k in range(len(obs)) if k not in in_fit]
    while True:
        dof = len(idx) - H.shape[1]
        T = global_statistic(v, var)
        if dof < 1:
            status = "no_test"
            thr = np.nan
            break
        thr = threshold(dof, cfg.p_fa)
        if T <= thr:
            status = "fault_excluded" if excluded else "ok"
            break
        if dof < 2 or len(excluded) >= cfg.max_exclusions:
            status = "fault_not_excluded"
            break
        w = standardized_residuals(H, v, var)
        j = int(np.argmax(np.abs(w)))
        k = int(idx[j])
        excluded.append((obs.sat_ids[k], float(w[j]), float(T)))
        counters["raim_exclusions"] += 1
        active[k] = False
        sub = obs.subset(np.flatnonzero(active))
        r2 = _least_squares(sub, states.subset(np.flatnonzero(active)), x[:4], [s for s in systems_all if any(c.system == s for c in sub.choices)],
                            cfg, use_mask=True)
        if r2 is None:
            status = "fault_not_excluded"
            break
        x, cor, H, v, var, idx_sub, it, systems = r2
        idx = np.flatnonzero(active)[idx_sub]
    used = np.zeros(len(obs), bool)
    used[idx] = True
    r = x[:3]
    lat, lon, _ = earth.ecef_to_geodetic(r)
    cov = lsq.covariance(H, 1.0 / var)
    if cov is None:                            # not seen: the last Gauss-Newton step solved the same geometry
        counters["epochs_too_few_satellites"] += 1
        return sol
    # residuals and geometry of every satellite at the final solution (excluded and masked ones too)
    # (without an exclusion the last Gauss-Newton evaluation is already this one: same satellites, x)
    full = cor if not excluded else corrected_at(obs, r, x[3], cfg.model, states)
    rs = np.einsum("kij,kj->ki", full.rot, full.r_sat_e_m)
    rho = np.linalg.norm(r - rs, axis=1)
    clk = np.array([x[3] + (x[3 + systems.index(c.system)] if c.system in systems and
                            systems.index(c.system) > 0 else 0.0) for c in obs.choices])
    sol = SppSolution(
        float(raw.t_s), float(raw.t_rx_gpst_s), status, r.copy(), cov[:3, :3], float(x[3]), systems[0],
        {s: float(x[3 + j]) for j, s in enumerate(systems) if j > 0}, dops(H, lat, lon), obs.sat_ids,
        full.pr_m - rho - clk, np.sqrt(full.var_m2), full.el_rad, full.az_rad, obs.cn0_dbhz[:, 0], obs.dual, used,
        excluded, below, float(global_statistic(v, var)), float(thr), int(len(idx) - H.shape[1]), int(it))
    counters[f"epochs_{status}"] += 1
    return sol


def precise_states(obs_list, states, precise, counters: Counter):
    """The satellite states of the systems ``precise`` (an
    :class:`~hyper_nav_gnss.orbits.precise.PreciseEphemeris`) covers taken from
    it instead of the broadcast records, at the same transmit time t_rx - P/c -
    dt_sv (the clock first at t_rx - P/c, then every state at the transmit
    time, as :func:`states_batch`), then moved to the clock reference of the
    broadcast record, which the group delays already applied to ``pr_m``
    assume (:func:`_precise_clock_to_record`). A satellite the product covers (its system) but
    cannot serve at that time (not listed, outside the span, a missing
    position or clock, with ``precise.antennas`` no offset for its signals)
    is removed from the epoch and counted under its reason
    (``precise_*``); systems the product does not hold keep their broadcast
    states. Returns the (obs_list, states) to solve."""
    from hyper_nav_gnss.corrections.receiver_model import SatelliteStates
    from hyper_nav_gnss.orbits.precise import REASONS
    from hyper_nav_gnss.signals import _F_B1I, _F_B3I
    k_if = _F_B1I ** 2 / (_F_B1I ** 2 - _F_B3I ** 2)
    systems = set(precise.systems)
    rows = [(e, k, s) for e, (o, st) in enumerate(zip(obs_list, states)) for k, s in enumerate(o.sat_ids)
            if s[0] in systems]
    if not rows:
        return obs_list, states
    ep_i = np.array([r[0] for r in rows], int)
    k_i = np.array([r[1] for r in rows], int)
    sats = [r[2] for r in rows]
    t = np.array([obs_list[e].t_rx_gpst_s for e in ep_i], float)
    tau = np.array([obs_list[e].pr_m[k] for e, k in zip(ep_i, k_i)]) / C_MPS
    c0, _ = precise.clock(sats, t, -tau)
    R, V, C, D, why = precise.states(sats, t, -tau - np.nan_to_num(c0))
    for j, (e, k) in enumerate(zip(ep_i, k_i)):
        C[j] += _precise_clock_to_record(obs_list[e].ephemerides[k], k_if)
    if precise.antennas is not None:
        R = R + _phase_centre_offsets(obs_list, ep_i, k_i, sats, t - tau, R, why, precise.antennas)
    keep = [np.ones(len(o), bool) for o in obs_list]
    new = [SatelliteStates(st.r_sat_e_m.copy(), st.v_sat_e_mps.copy(), st.clock_s.copy(), st.clock_drift_sps.copy())
           for st in states]
    for j, (e, k) in enumerate(zip(ep_i, k_i)):
        if why[j] >= 0:
            keep[e][k] = False
            counters[REASONS[why[j]]] += 1
        else:
            st = new[e]
            st.r_sat_e_m[k], st.v_sat_e_mps[k], st.clock_s[k], st.clock_drift_sps[k] = R[j], V[j], C[j], D[j]
            counters["precise_satellite_epochs"] += 1
    out_obs, out_st = [], []
    for o, st, kp in zip(obs_list, new, keep):
        if kp.all():
            out_obs.append(o)
            out_st.append(st)
        else:
            idx = np.flatnonzero(kp)
            out_obs.append(o.subset(idx))
            out_st.append(st.subset(idx))
    return out_obs, out_st


def _phase_centre_offsets(obs_list, ep_i, k_i, sats, t_tx_gpst_s, R, why, antennas):
    """ECEF offset centre of mass -> antenna phase centre of each row's
    signal or ionosphere-free pair (:mod:`hyper_nav_gnss.orbits.satellite_antenna`;
    the ANTEX frequency of a signal is its system and RINEX band: G01,
    E07, C06); a row whose offset the file does not give gets reason
    ``precise_no_antenna`` in ``why`` (in place). Returns (n, 3) [m]."""
    from hyper_nav_gnss.orbits.precise import REASONS
    from hyper_nav_gnss.orbits.satellite_antenna import pco_ecef_m
    no_ant = REASONS.index("precise_no_antenna")
    body = np.zeros((len(sats), 3))
    for j, (e, k, sat) in enumerate(zip(ep_i, k_i, sats)):
        if why[j] >= 0:
            continue
        o = obs_list[e]
        a1, a2 = o.coef[k]                   # P_IF = a1 P1 - a2 P2 (a1 = 1, a2 = 0 single)
        for code, w in zip(o.choices[k].codes, (a1, -a2)):
            p = antennas.pco_body_m(sat, f"{sat[0]}0{code[0]}", float(t_tx_gpst_s[j]))
            if p is None:
                why[j] = no_ant
                break
            body[j] += w * p
    ok = why < 0
    d = np.zeros((len(sats), 3))
    if ok.any():
        d[ok] = pco_ecef_m(body[ok], R[ok], t_tx_gpst_s[ok])
    return d


def _precise_clock_to_record(eph, k_if: float) -> float:
    """dt_record - dt_precise [s] of one satellite: IGS (MGEX) precise
    clocks refer to GPS L1/L2 (as LNAV: 0), Galileo E1/E5a (as F/NAV; an
    I/NAV record's E1/E5b clock is dt_INAV = dt_FNAV + BGD(E1,E5b) -
    BGD(E1,E5a), OS SIS ICD 5.1.5, :mod:`.signal_delays`) and BeiDou B1I/B3I
    (broadcast: B3I, dt_B3I = dt_IF + f1^2/(f1^2 - f3^2) TGD1)."""
    if eph.system == "C":
        return k_if * eph.tgd
    if eph.system == "E":
        from hyper_nav_gnss.orbits.ephemeris import GAL_CLOCK_E1E5A, GAL_CLOCK_E1E5B
        fnav = bool(eph.data_source & GAL_CLOCK_E1E5A) and not (eph.data_source & GAL_CLOCK_E1E5B)
        return 0.0 if fnav else eph.tgd2 - eph.tgd
    return 0.0


def solve(epochs, store, cfg: SppConfig, counters: Counter | None = None, x0=None,
          batched: bool = True, precise=None) -> list[SppSolution]:
    """SPP of every epoch, each started from the previous valid solution (the
    first from ``x0`` = [x, y, z, b], e.g. a RINEX header's approximate
    position; None = the Earth's centre).

    ``batched``: the epochs of a block are solved together
    (:func:`_batch_solve`, the same iterations on arrays of every epoch)
    where that gives what :func:`solve_epoch` gives; an epoch the batch does
    not settle (too few satellites, a RAIM alarm, no degree of freedom, no
    start yet, or the epoch after such one) is solved by :func:`solve_epoch`
    from the previous solution, as before.

    ``precise``: a :class:`~hyper_nav_gnss.orbits.precise.PreciseEphemeris`
    whose orbits and clocks replace the broadcast ones for the systems it
    holds (:func:`precise_states`); None = broadcast only."""
    counters = counters if counters is not None else Counter()
    out = []
    for a in range(0, len(epochs), BATCH_EPOCHS):
        block = epochs[a:a + BATCH_EPOCHS]
        obs_list = [satellite_observations(raw, store, cfg.model, counters, exclude=cfg.exclude) for raw in block]
        states = states_batch(obs_list)
        if precise is not None:
            obs_list, states = precise_states(obs_list, states, precise, counters)
        k0 = 0
        while batched and k0 < len(block) and (x0 is None or not np.all(np.isfinite(x0))):
            s = solve_epoch(block[k0], store, cfg, x0, counters, obs=obs_list[k0],      # no start yet: one by one
                            states=states[k0] if len(obs_list[k0]) >= 4 else None)
            out.append(s)
            if s.valid:
                x0 = np.concatenate([s.pos_ecef_m, [s.clock_bias_m]])
            k0 += 1
        block, obs_list, states = block[k0:], obs_list[k0:], states[k0:]
        start = None if x0 is None or not np.all(np.isfinite(x0)) else np.asarray(x0, float)[:4]
        batch = _batch_solve(block, obs_list, states, cfg, start) if batched and start is not None and block else None
        prev_from_batch = True
        for k, (raw, obs, st) in enumerate(zip(block, obs_list, states)):
            s = batch[k] if batch is not None and prev_from_batch else None
            if s is None:
                s = solve_epoch(raw, store, cfg, x0, counters, obs=obs, states=st if len(obs) >= 4 else None)
                prev_from_batch = False
            else:
                counters[f"epochs_{s.status}"] += 1
                prev_from_batch = True
            out.append(s)
            if s.valid:
                x0 = np.concatenate([s.pos_ecef_m, [s.clock_bias_m]])
            if not s.valid and s.status != "too_few_satellites":
                prev_from_batch = False
    return out


class _Block:
    """The satellites of a block of epochs as (epochs x satellites) arrays,
    padded rows flagged off in ``row``."""

    def __init__(self, obs_list, states, cfg: SppConfig):
        E = len(obs_list)
        S = max([len(o) for o in obs_list] + [1])
        self.E, self.S = E, S
        self.row = np.zeros((E, S), bool)
        self.r_s = np.tile(np.array([2.6e7, 0.0, 0.0]), (E, S, 1))
        self.clk = np.zeros((E, S))
        self.we = np.zeros((E, S))
        self.pr0 = np.zeros((E, S))
        self.scale = np.zeros((E, S))
        self.dual = np.ones((E, S), bool)
        self.sys = np.full((E, S), -1)
        self.acc = np.ones((E, S))
        self.coef = np.zeros((E, S, 2))
        cn0 = np.full((E, S, 2), 45.0)
        self.t_rx = np.zeros(E)
        self.ok_epoch = np.zeros(E, bool)
        for e, (o, st) in enumerate(zip(obs_list, states)):
            n = len(o)
            self.t_rx[e] = o.t_rx_gpst_s
            if n < 4:
                continue
            we, systems, acc = _static(o)
            self.row[e, :n] = True
            self.r_s[e, :n] = st.r_sat_e_m
            self.clk[e, :n] = st.clock_s
            self.we[e, :n] = we
            self.pr0[e, :n] = o.pr_m
            self.scale[e, :n] = o.iono_scale
            self.dual[e, :n] = o.dual
            self.sys[e, :n] = [SYSTEM_ORDER.index(q) for q in systems]
            self.acc[e, :n] = acc
            self.coef[e, :n] = o.coef
            cn0[e, :n] = o.cn0_dbhz
            self.ok_epoch[e] = True
        # the C/N0 parts of the weights (receiver_model._cn0_parts, element by element)
        self.c = [cn0[..., 0], np.where(np.isfinite(cn0[..., 1]), cn0[..., 1], cn0[..., 0])]
        if cfg.model.errors is not None:
            self.parts = [cfg.model.errors.cn0_var_m2(c) for c in self.c]
            for finite, valid, _ in self.parts:          # a finite C/N0 <= 0: the per-epoch path (its default sigma)
                self.ok_epoch &= ~(finite & ~valid).any(axis=1)

    def evaluate(self, r, b, model):
        """:func:`.receiver_model.corrected_at` of every epoch at once (receiver
        near the Earth's surface): (rotated satellite positions, corrected
        pseudoranges, variances, elevations, azimuths, lat, lon)."""
        tau = np.sqrt(np.sum((self.r_s - r[:, None, :]) ** 2, axis=2)) / C_MPS
        c, s = np.cos(self.we * tau), np.sin(self.we * tau)
        x, y, z = self.r_s[..., 0], self.r_s[..., 1], self.r_s[..., 2]
        rr = np.stack([c * x + s * y, -s * x + c * y, z], axis=2)
        lat, lon, alt = earth.ecef_to_geodetic(r)
        sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
        d = rr - r[:, None, :]
        e_ = -so[:, None] * d[..., 0] + co[:, None] * d[..., 1]
        n_ = (-sl * co)[:, None] * d[..., 0] + (-sl * so)[:, None] * d[..., 1] + cl[:, None] * d[..., 2]
        u_ = (cl * co)[:, None] * d[..., 0] + (cl * so)[:, None] * d[..., 1] + sl[:, None] * d[..., 2]
        el = np.arctan2(u_, np.hypot(e_, n_))
        az = np.mod(np.arctan2(e_, n_), 2 * np.pi)
        iono = np.zeros_like(el)
        single = ~self.dual & self.row
        if single.any():
            t_rx = (self.t_rx - b / C_MPS)[:, None]
            for j, sysc in enumerate(SYSTEM_ORDER):
                k = single & (self.sys == j)
                ab = model.klobuchar_for(sysc) if k.any() else None
                if ab is None:
                    continue
                kb = klobuchar_delay_m(ab[0], ab[1], lat[:, None], lon[:, None], np.maximum(el, 0.0), az, t_rx)
                iono = np.where(k, kb * self.scale, iono)
        tropo = hopfield_delay_m(np.maximum(el, 0.0), alt[:, None])[0] if model.troposphere else np.zeros_like(el)
        pr = self.pr0 + C_MPS * self.clk - iono - tropo
        em = model.errors
        v1 = em.receiver_var_m2(el, self.c[0], self.parts[0])
        v2 = em.receiver_var_m2(el, self.c[1], self.parts[1])
        rx = self.coef[..., 0] ** 2 * v1 + self.coef[..., 1] ** 2 * v2
        var = rx + em.model_var_m2(el, self.acc, iono, self.dual)
        return rr, pr, np.where(self.row, var, 1.0), el, az


def _batch_solve(block, obs_list, states, cfg: SppConfig, start) -> list:
    """:func:`solve_epoch` of every epoch of a block on arrays, for the
    epochs where no satellite is excluded: twice, first every epoch from
    ``start``, then each from the previous epoch's first-pass solution (the
    start :func:`solve` gives it, to the last few digits), with the same
    Gauss-Newton steps, elevation mask, stop rule and residual test. Returns
    per epoch an SppSolution, or None where :func:`solve_epoch` must decide
    (fewer than 4 satellites, too few above the mask, a RAIM alarm, no
    degree of freedom, C/N0 <= 0, receiver-sigma weighting)."""
    if cfg.model.errors is None:
        return None
    blk = _Block(obs_list, states, cfg)
    E = blk.E
    x_first = _batch_gauss_newton(blk, cfg, np.tile(start, (E, 1)), blk.ok_epoch.copy())
    if x_first is None:
        return None
    xs = x_first[0]
    good = x_first[-1]
    starts = np.empty((E, 4))
    last = np.asarray(start, float)
    for e in range(E):                          # each epoch from the previous first-pass solution
        starts[e] = last
        if good[e]:
            last = xs[e, :4]
    res = _batch_gauss_newton(blk, cfg, starts, blk.ok_epoch.copy())
    if res is None:
        return None
    x, m, ok, H, it, pr, var, el, az, rr, slot, sysp, good = res
    # everything :func:`solve_epoch` reports, for every epoch at once (unused clock columns: identity)
    P = H.shape[2]
    unused = np.arange(P)[None, :] >= m[:, None]
    eye = np.zeros((E, P, P))
    eye[:, np.arange(P), np.arange(P)] = unused
    r = x[:, :3]
    rho_all = np.sqrt(np.sum((r[:, None, :] - rr) ** 2, axis=2))
    v_all = pr - (rho_all + np.einsum("esj,ej->es", H[..., 3:], x[:, 3:]))
    W = np.where(ok, 1.0 / var, 0.0)
    T_all = np.sum(np.where(ok, v_all * v_all * W, 0.0), axis=1)
    dof_all = ok.sum(axis=1) - m
    try:
        cov = np.linalg.inv(lsq.normal_matrix(H, W) + eye)
        Q = np.linalg.inv(lsq.normal_matrix(H, np.ones_like(W)) + eye)        # the DOPs' geometry (:mod:`.dop`)
    except np.linalg.LinAlgError:
        return None
    lat, lon, _ = earth.ecef_to_geodetic(r)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    Cne = np.stack([np.stack([-so, -sl * co, cl * co], 1), np.stack([co, -sl * so, cl * so], 1),
                    np.stack([np.zeros(E), cl, sl], 1)], 1)                    # ENU -> ECEF per epoch
    Qp = np.einsum("eji,ejk,ekl->eil", Cne, Q[:, :3, :3], Cne)
    qd = np.diagonal(Q, axis1=1, axis2=2)
    gdop = np.sqrt(np.sum(np.where(unused, 0.0, qd), axis=1))
    pdop = np.sqrt(qd[:, 0] + qd[:, 1] + qd[:, 2])
    hdop, vdop, tdop = np.sqrt(Qp[:, 0, 0] + Qp[:, 1, 1]), np.sqrt(Qp[:, 2, 2]), np.sqrt(qd[:, 3])
    sys_safe = np.maximum(blk.sys, 0)
    rows = np.arange(E)[:, None]
    present = sysp[rows, sys_safe]
    isb_slot = slot[rows, sys_safe]
    clk_all = x[:, 3:4] + np.where(present & (isb_slot > 0), np.take_along_axis(x, 3 + np.maximum(isb_slot, 0), 1),
                                   0.0)
    out = [None] * E
    for e in np.flatnonzero(good & (dof_all >= 1)):
        dof = int(dof_all[e])
        T = float(T_all[e])
        thr = threshold(dof, cfg.p_fa)
        if not T <= thr:
            continue
        o, raw = obs_list[e], block[e]
        n = len(o)
        me = int(m[e])
        xe = x[e, :me]
        systems = [SYSTEM_ORDER[j] for j in range(len(SYSTEM_ORDER)) if sysp[e, j]]
        used = ok[e, :n].copy()
        sat_ids = o.sat_ids
        out[e] = SppSolution(
            float(raw.t_s), float(raw.t_rx_gpst_s), "ok", xe[:3].copy(), cov[e, :3, :3].copy(), float(xe[3]),
            systems[0], {q: float(xe[3 + j]) for j, q in enumerate(systems) if j > 0},
            {"gdop": float(gdop[e]), "pdop": float(pdop[e]), "hdop": float(hdop[e]), "vdop": float(vdop[e]),
             "tdop": float(tdop[e])}, sat_ids,
            pr[e, :n] - rho_all[e, :n] - clk_all[e, :n], np.sqrt(var[e, :n]), el[e, :n], az[e, :n],
            o.cn0_dbhz[:, 0], o.dual, used, [], [sat_ids[k] for k in np.flatnonzero(~used)], T, float(thr), dof,
            int(it[e]))
    return out


def _batch_gauss_newton(blk: _Block, cfg: SppConfig, x0, active):
    """The iterations of :func:`_least_squares` (``use_mask``, a start near the
    antenna) for every active epoch at once. Returns (x, m, ok, H, iterations,
    pr, var, el, az, rotated satellites, system slots, systems present, good)
    at the end, good False where an epoch had too few satellites or a
    singular system; or None when no epoch is active.

    The clock columns and the normal equations are :mod:`.least_squares`'s,
    broadcast over the epochs (padded rows have weight 0). The step itself is
    solved here, not by :func:`.least_squares.solve_step`: an epoch with
    fewer systems than the block's widest has unused clock columns, which get
    a unit diagonal in N (dx 0 there) before one stacked ``solve``; and one
    singular epoch fails the whole stacked solve (None: the block goes to
    :func:`solve_epoch`), where the per-epoch solve would flag that epoch
    only."""
    model = cfg.model
    E, S = blk.E, blk.S
    active = active & (np.linalg.norm(x0[:, :3], axis=1) > 6.0e6)
    if not active.any():
        return None
    NS = len(SYSTEM_ORDER)
    x = np.zeros((E, 3 + NS))
    x[:, :4] = x0[:, :4]
    m_prev = np.full(E, -1)
    done = ~active
    good = active.copy()
    it_of = np.zeros(E, int)
    H = np.zeros((E, S, 3 + NS))
    ok = np.zeros((E, S), bool)
    m = np.full(E, 4)
    slot = np.zeros((E, NS), int)
    sysp = np.zeros((E, NS), bool)
    rows = np.arange(E)
    for it in range(1, cfg.max_iterations + 1):
        run = ~done
        if not run.any():
            break
        rr, pr, var, el, az = blk.evaluate(x[:, :3], x[:, 3], model)
        ok_new = (el >= model.elevation_mask_rad) & blk.row
        sysp_new = np.stack([(ok_new & (blk.sys == j)).any(axis=1) for j in range(NS)], axis=1)
        m_new = 3 + sysp_new.sum(axis=1)
        few = run & (ok_new.sum(axis=1) < m_new)
        good &= ~few
        done |= few
        run &= ~few
        ok[run], sysp[run], m[run] = ok_new[run], sysp_new[run], m_new[run]
        slot[run] = np.cumsum(sysp_new[run], axis=1) - 1
        reset = run & (m != m_prev)
        x[reset, 4:] = 0.0
        m_prev[run] = m[run]
        d = x[:, None, :3] - rr
        rho = np.sqrt(np.sum(d * d, axis=2))
        sl_of = np.where(blk.sys >= 0, slot[rows[:, None], np.maximum(blk.sys, 0)], -1)
        Hn = np.concatenate([d / rho[..., None], lsq.clock_columns_from_slots(sl_of, NS)], axis=2) * ok[..., None]
        H[run] = Hn[run]
        pred = rho + np.einsum("esj,ej->es", H[..., 3:], x[:, 3:])
        v = np.where(ok, pr - pred, 0.0)
        w = np.where(ok, 1.0 / var, 0.0)
        N, rhs = lsq.normal_equations(H, v, w)
        unused = np.arange(3 + NS)[None, :] >= m[:, None]
        N[:, np.arange(3 + NS), np.arange(3 + NS)] += unused
        try:
            dx = np.linalg.solve(N[run], rhs[run][..., None])[..., 0]
        except np.linalg.LinAlgError:
            return None
        x[run] += dx
        it_of[run] = it
        step = np.linalg.norm(dx[:, :3], axis=1)
        stop = np.zeros(E, bool)
        stop[run] = (it > 1) & ((step < cfg.tol_m) | (step < cfg.warm_tol_m))
        done |= stop
    rr, pr, var, el, az = blk.evaluate(x[:, :3], x[:, 3], model)
    return x, m, ok, H, it_of, pr, var, el, az, rr, slot, sysp, good


@dataclass
class SppVelocity:
    """Receiver velocity from Doppler (pseudorange rates) at a solved epoch."""
    t_s: float
    vel_enu_mps: np.ndarray
    cov_enu_m2ps2: np.ndarray
    clock_drift_mps: float
    n_used: int

    @property
    def sigma_enu_mps(self) -> np.ndarray:
        return np.sqrt(np.diag(self.cov_enu_m2ps2))


def solve_velocity(raw, store, cfg: SppConfig, sol: SppSolution, max_w: float = 5.0) -> SppVelocity | None:
    """Weighted least squares velocity and clock drift from the pseudorange
    rates of one epoch at its SPP position (Groves 2nd ed. eq. 9.142; RTKLIB
    manual E.6.10 without the Sagnac rate term, < 5 mm/s here):

        rate_j + c dts_dot_j - u_j . v_sat_j = -u_j . v_rx + d,

    u_j the unit line of sight receiver -> satellite (ECEF), d the receiver
    clock drift (m/s, one oscillator for every system). Satellites below the
    elevation mask or without a Doppler are left out; the largest
    standardized residual above ``max_w`` is removed while 5 remain. The
    covariance is scaled by the unit-weight variance when that exceeds 1.
    None when fewer than 5 satellites remain or their geometry is singular
    (the solve: :func:`.least_squares.solve_linear`)."""
    if not sol.valid:
        return None
    obs = satellite_observations(raw, store, cfg.model, Counter(), exclude=cfg.exclude)
    if len(obs) < 5:
        return None
    states = states_from_pseudoranges(obs)
    cor = corrected_at(obs, sol.pos_ecef_m, sol.clock_bias_m, cfg.model, states)
    ch0 = np.array([c.channels[0] for c in obs.choices], int)
    rate = np.asarray(raw.rate_mps, float)[ch0] + C_MPS * cor.sat_clock_drift_sps
    var = np.asarray(raw.rate_sigma_mps, float)[ch0] ** 2
    rs = np.einsum("kij,kj->ki", cor.rot, cor.r_sat_e_m)
    vs = np.einsum("kij,kj->ki", cor.rot, cor.v_sat_e_mps)
    u = rs - sol.pos_ecef_m
    u /= np.linalg.norm(u, axis=1)[:, None]
    y = rate - np.einsum("ki,ki->k", u, vs)
    ok = np.isfinite(y) & np.isfinite(var) & (var > 0) & (cor.el_rad >= cfg.model.elevation_mask_rad)
    idx = np.flatnonzero(ok)
    while len(idx) >= 5:
        H = np.hstack([-u[idx], np.ones((len(idx), 1))])
        W = 1.0 / var[idx]
        lin = lsq.solve_linear(H, y[idx], W)
        if lin is None:
            return None
        x, Q, v = lin
        s_v = np.sqrt(np.maximum(var[idx] - np.einsum("ki,ij,kj->k", H, Q, H), 1e-12))
        w = np.abs(v) / s_v
        j = int(np.argmax(w))
        if w[j] > max_w and len(idx) > 5:
            idx = np.delete(idx, j)
            continue
        dof = len(idx) - 4
        f = max(1.0, float(v @ (W * v)) / dof) if dof > 0 else 1.0
        lat, lon, _ = earth.ecef_to_geodetic(sol.pos_ecef_m)
        R = earth.C_n_e(lat, lon).T                      # ECEF -> ENU
        return SppVelocity(sol.t_s, R @ x[:3], R @ (Q[:3, :3] * f) @ R.T, float(x[3]), len(idx))
    return None
