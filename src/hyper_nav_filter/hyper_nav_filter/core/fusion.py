"""Fusion engine: the error-state filter fed by time-stamped IMU samples,
aiding measurements and model updates.

Events are processed in timestamp order whatever order they arrive in. The
engine keeps, for ``reprocess_window_s``, every IMU sample and the filter
snapshot after each IMU epoch. An event stamped before the latest IMU epoch
(late, e.g. a GNSS fix delivered 200 ms after its epoch, or a model update
computed by a slow aiding node) marks the stored epochs from its epoch on;
before the next step the engine restores the snapshot before that epoch and
re-runs the stored samples and events from there, so the result is the same
as on-time delivery. Model updates (``core.model_update``) are applied at
their epoch and the configuration in force is part of every snapshot.

Solutions are released ``output_delay_s`` behind the latest IMU epoch on a
fixed grid of ``output_rate_hz`` (t0 + n / rate), which makes them
independent of arrival order for delays up to that value (the live node and
an offline run over a bag give identical numbers).

Current time (STYLE pattern 19): the filter fuses up to the *fusion
horizon*, ``fusion_delay_s`` behind the newest IMU sample (0: at it); the
samples ahead of it wait in a buffer, so a measurement delivered within its
declared delay is never late (no re-processing). At every accepted IMU
sample the engine also forms ``current``: the state at that sample's stamp,
the filter's newest state carried over the buffered samples by the output
predictor (``core.output_predictor``) with the estimated sensor errors, its
covariance carried over the lead. The released solutions do not depend on
the horizon (the same epochs with the same events); the current-time stream
depends on arrival order by nature (``replay_order`` reproduces it).

IMU gaps: an interval longer than ``imu_gap_s`` (a hole in a bag, a dropped
stream) is bridged up to one nominal interval before the new sample with
body rates interpolated linearly between the last sample before the gap and
the first after it, in steps of the nominal interval (at most 1000), so the
time line continues and measurements inside the gap still apply; the
covariance is inflated by the unknown deviation of specific force and rate
from that interpolation (``gap_accel_sigma_mps2``, ``gap_rate_sigma_deg_per_s``)
so that the next aiding data is accepted and pulls the solution back. The gap is counted
(``imu_gaps``, ``imu_gap_total_s``) and the solutions in it are flagged
INS_ONLY. The engine never stalls.
"""
from __future__ import annotations

import bisect
import math
from collections import Counter

import numpy as np

from .config import FilterConfig
from .eskf import ErrorStateKF
from .measurements import ModelContext, is_finite
from .model_update import ModelUpdate
from .nav_state import ImuSample, NavState
from .output_predictor import OutputPredictor
from .params import ConfigError

# NavState.msg modes
MODE_INITIALIZING, MODE_INS_ONLY, MODE_LOOSELY_COUPLED, MODE_TIGHTLY_COUPLED, MODE_AIDED = 1, 2, 3, 4, 5
MODE_NAMES = {MODE_INITIALIZING: "initializing", MODE_INS_ONLY: "INS only", MODE_LOOSELY_COUPLED: "loosely coupled",
              MODE_TIGHTLY_COUPLED: "tightly coupled", MODE_AIDED: "aided (non-GNSS)"}
_COUPLING_MODE = {"tight": MODE_TIGHTLY_COUPLED, "loose": MODE_LOOSELY_COUPLED, "aiding": MODE_AIDED}
MODE_WINDOW_S = 1.0            # a source counts toward the mode for this long after an accepted update
_EPS_S = 1e-9
_MODEL_UPDATE, _MEASUREMENT = 0, 1   # an event's queue priority (a model update before the measurements of its
                                     # epoch), given by its entry point: ``_apply`` knows what each event is by it


def _tol(t: float) -> float:
    """Stamp tolerance at t: 1 ns, or 4 ulps of t where 1 ns is below the
    float's resolution (GPST or Unix stamps, ~1e9 s: 4 ulps = 1 us). Without
    it an event stamped at an epoch that reached the engine before the
    epoch's IMU sample was never applied at such stamps (t + 1e-9 == t)."""
    if -_TOL_ULP_FROM < t < _TOL_ULP_FROM:     # 4 ulps < 1 ns below 2^21 s: no ulp to take (per event and epoch)
        return _EPS_S
    return max(_EPS_S, 4.0 * math.ulp(t))


_TOL_ULP_FROM = 2.0 ** 21                    # ulp(t) <= 2^-32 s below it: 4 ulps <= 0.93 ns
_TRIM_CHUNK = 64               # epochs out of the window are dropped from memory this many at a time


def _vec(x) -> np.ndarray:
    return x if type(x) is np.ndarray and x.dtype == np.float64 else np.asarray(x, dtype=float)


def make_filter(cfg: FilterConfig, initial: NavState) -> ErrorStateKF:
    """The error-state filter of the configured mechanization frame."""
    return ErrorStateKF(cfg, initial)


class Solution:
    """A released solution at epoch t_s: the geodetic/ENU state with the
    ENU-convention covariance, its mode and counters, and the corrected body
    rate and specific force of its last IMU interval. Built lazily from the
    filter snapshot by the engine (``Solution.of``): the state view and the
    covariance transform are computed when read."""
    __slots__ = ("t_s", "mode", "n_updates", "n_rejected", "last_nis", "sources", "_state", "_P", "_w", "_f", "_src")

    def __init__(self, t_s, state, P, mode, n_updates, n_rejected, last_nis, omega_ib_b_radps=None, f_b_mps2=None,
                 sources=()):
        self.t_s, self.mode, self.n_updates, self.n_rejected, self.last_nis = t_s, mode, n_updates, n_rejected, \
            last_nis
        self.sources = sources
        self._state, self._P, self._w, self._f, self._src = state, P, omega_ib_b_radps, f_b_mps2, None

    @classmethod
    def of(cls, kf, snap, imu, mode, sources) -> "Solution":
        sol = cls(imu.t_s, None, None, mode, snap.n_updates, snap.n_rejected, snap.last_nis, sources=sources)
        sol._src = (kf, snap, imu)
        return sol

    @property
    def state(self) -> NavState:
        if self._state is None:
            kf, snap, _ = self._src
            self._state = kf.snapshot_state(snap)
        return self._state

    @property
    def P(self) -> np.ndarray:
        if self._P is None:
            kf, snap, _ = self._src
            self._P = kf.P_enu(snap)
        return self._P

    def _rates(self):
        kf, snap, imu = self._src
        if imu is None:                           # the time line's first sample (no interval flown yet)
            self._w, self._f = np.zeros(3), np.zeros(3)
            return
        dth, dv = kf.corrected(imu.dtheta_b_rad, imu.dvel_b_mps, imu.dt_s, snap.values)
        self._w, self._f = dth / imu.dt_s, dv / imu.dt_s

    @property
    def omega_ib_b_radps(self) -> np.ndarray:
        if self._w is None:
            self._rates()
        return self._w

    @property
    def f_b_mps2(self) -> np.ndarray:
        if self._f is None:
            self._rates()
        return self._f


class CurrentSolution(Solution):
    """The current-time state (``FusionEngine.current``): a ``Solution`` at
    the newest IMU sample, from the output predictor; its covariance is the
    fusion horizon's carried over the lead, computed when read."""
    __slots__ = ("pred", "_predictor")

    @classmethod
    def of_prediction(cls, kf, predictor, pred, mode, sources) -> "CurrentSolution":
        a = pred.anchor
        sol = cls(pred.t_s, None, None, mode, a.n_updates, a.n_rejected, a.last_nis, sources=sources)
        if pred.x_nav is a.x_nav and pred.t_s == a.t_s and pred.values is a.values and pred.imu is a.imu_prev:
            snap = a                              # no lead: the anchor itself (the same fields)
        else:
            snap = a._replace(t_s=pred.t_s, x_nav=pred.x_nav, values=pred.values, imu_prev=pred.imu)
        sol._src = (kf, snap, pred.imu)
        sol.pred, sol._predictor = pred, predictor
        return sol

    @property
    def lead_s(self) -> float:
        """How far (s) the state is predicted ahead of the filter's."""
        return self.pred.lead_s

    @property
    def P(self) -> np.ndarray:
        if self._P is None:
            kf, snap, _ = self._src
            self._P = kf.P_enu(snap._replace(P=self._predictor.covariance(self.pred)))
        return self._P


def _lazy_source(sols):
    """The filter all of ``sols`` are lazy views of (``Solution.of`` /
    ``CurrentSolution.of_prediction``, not yet read), else None."""
    if not sols:
        return None
    kf = None
    for s in sols:
        src = getattr(s, "_src", None)
        if src is None or s._state is not None or type(s) not in (Solution, CurrentSolution):
            return None
        if kf is None:
            kf = src[0]
        elif src[0] is not kf:
            return None
    return kf


def solution_arrays(sols) -> dict | None:
    """{"t", "lat", "lon", "alt", "vel", "C"} of many solutions at once, the
    numbers each ``.state`` gives, read from the snapshots' nominal vectors in
    one array operation when the frame's view is a reading of its vector
    (``frame.view_rows``: ENU); None otherwise (the caller reads ``.state``).
    (672,400 solutions: one stack instead of a NavState each.)"""
    kf = _lazy_source(sols)
    view_rows = getattr(kf.frame, "view_rows", None) if kf is not None else None
    if view_rows is None:
        return None
    out = {"t": np.array([s.t_s for s in sols])}
    out.update(view_rows(np.array([s._src[1].x_nav for s in sols])))
    return out


def solution_covariances(sols) -> list:
    """``s.P`` of each solution (the same arrays): where the frame's error
    convention is ENU's (``to_enu`` the identity), the snapshot's own P, or
    for a current-time state with no lead its anchor's P, without the
    per-solution transform and prediction calls."""
    kf = _lazy_source(sols)
    if kf is None or not getattr(kf.frame, "enu_convention", False):
        return [s.P for s in sols]
    out = []
    for s in sols:
        if s._P is not None:
            out.append(s._P)
        elif type(s) is Solution:
            out.append(s._src[1].P)
        elif s.pred.imu is None or s.pred.lead_s <= 0.0:       # OutputPredictor.covariance with no lead
            out.append(s.pred.anchor.P)
        else:
            out.append(s.P)
    return out


class _Epoch:
    """One stored IMU epoch: its sample, the filter snapshot after its
    updates, the last acceptance time per (kind, coupling), an IMU-gap
    covariance inflation, the key of the last event applied and the model
    context of the epoch, and the smoother's per-epoch quantities."""
    __slots__ = ("imu", "snap", "last_accept", "extra_Q", "last_key", "ctx", "Phi", "P_prior", "dx")

    def __init__(self, imu, snap, last_accept, extra_Q=None):
        self.imu, self.snap, self.last_accept, self.extra_Q = imu, snap, last_accept, extra_Q
        self.last_key = self.ctx = self.Phi = self.P_prior = self.dx = None


class FusionEngine:
    def __init__(self, cfg: FilterConfig, initial: NavState, keep_history: bool = False):
        """``keep_history`` stores every epoch for the offline RTS smoother."""
        self.cfg = cfg
        self.keep_history = keep_history
        self.history: list[_Epoch] = []
        self.kf = make_filter(cfg, initial.copy())
        self._base = self.kf.snapshot()          # state before the first stored epoch
        self._base_accept: dict = {}
        self._epochs: list[_Epoch] = []
        self._times: list[float] = []
        self._n_out_of_window = 0                 # leading epochs already out of the window (see _trim)
        self._mode_cache = ()                     # (last_accept, t_lo, t_hi, result), up to two (_mode)
        self._events: list[tuple] = []           # sorted (t, priority, kind, seq, event): arrival order
                                                  # within an epoch does not matter
        self._seq = 0
        self._at = -1                             # index of the epoch the filter is at (-1: base)
        self._dirty_from = math.inf               # earliest epoch a late event touched
        self._t0_out = float(initial.t_s)
        self._n_out = 0                           # next output time = t0 + n / rate
        self._released = 0                        # epochs [0, _released) of _epochs are released
        self._last_released_t = -math.inf
        self._last_dt = None
        self._pending_gap_Q = None
        self.counters: Counter = Counter()
        self.gaps: list[tuple[float, float]] = []
        self._ahead: list[ImuSample] = []         # samples ahead of the fusion horizon ...
        self._ahead_Q: list = []                  # ... and their IMU-gap inflations
        self._new: list = []                      # samples accepted since the last current state
        self._revision = 0                        # corrections applied (the output predictor follows it)
        self.predictor = OutputPredictor(self.kf, cfg.output_predictor, cfg.output_tau_att_s,
                                         cfg.output_tau_vel_s, cfg.output_tau_pos_s)
        self.fusion_delay_s = float(cfg.fusion_delay_s)
        self.current: CurrentSolution | None = None   # the state at the newest IMU sample
        self.current_log: list | None = None      # a list: every current-time state is kept (offline replay)

    @property
    def t_latest_s(self) -> float:
        """Stamp of the newest IMU sample."""
        if self._ahead:
            return self._ahead[-1].t_s
        return self._times[-1] if self._times else self._base.t_s

    @property
    def t_horizon_s(self) -> float:
        """Stamp of the filter's newest epoch (the fusion horizon)."""
        return self._times[-1] if self._times else self._base.t_s

    def set_fusion_delay(self, delay_s: float) -> None:
        """The fusion horizon (s behind the newest IMU sample): the largest
        declared source delay (``sources``) or ``fusion_delay_s``, at most
        ``output_delay_s``. Set before the first sample."""
        if self._times or self._ahead:
            raise RuntimeError("set_fusion_delay: the engine has started")
        if not 0.0 <= delay_s <= self.cfg.output_delay_s:
            raise ConfigError(f"fusion delay {delay_s:g} s: must be within [0, output_delay_s = "
                              f"{self.cfg.output_delay_s:g}] (a declared source delay too long for the record)")
        self.fusion_delay_s = float(delay_s)

    @property
    def last_released_t_s(self) -> float:
        """Epoch of the newest solution released so far (-inf before the first):
        an event at or before it is applied, but the solutions already
        released did not see it."""
        return self._last_released_t

    # ---- inputs -------------------------------------------------------------------
    def add_imu(self, t_s: float, dtheta_b_rad, dvel_b_mps, load_f_b_mps2=None) -> tuple[bool, str]:
        """Add an IMU sample stamped at the end of its interval; ``load_f_b_mps2``
        the structure's load over it when a source gives it (``ImuSample``: the
        interval mean (3,) or the means over its n equal sub-intervals (n, 3)).
        Returns (accepted, reason); rejected samples are counted, never raised."""
        dth = _vec(dtheta_b_rad)
        dv = _vec(dvel_b_mps)
        ok, reason = self._check_imu_time(t_s, dth, dv)
        if not ok:
            return ok, reason
        self._accept_imu(t_s, dth, dv, load=None if load_f_b_mps2 is None else _vec(load_f_b_mps2))
        return True, "ok"

    def add_imu_rates(self, t_s: float, omega_b_radps, f_b_mps2, load_f_b_mps2=None) -> tuple[bool, str]:
        """Add an IMU sample given as mean rates over its interval (the
        sensor_msgs/Imu mapping): increments = rate * (t_s - t_latest), or
        rate * the nominal interval after a gap; ``load_f_b_mps2`` as in
        ``add_imu``."""
        w = _vec(omega_b_radps)
        f = _vec(f_b_mps2)
        ok, reason = self._check_imu_time(t_s, w, f)
        if not ok:
            return ok, reason
        dt = t_s - self.t_latest_s
        self._accept_imu(t_s, w * dt, f * dt, rates=(w, f), load=None if load_f_b_mps2 is None else _vec(load_f_b_mps2))
        return True, "ok"

    def _check_imu_time(self, t_s, a, b) -> tuple[bool, str]:
        if not math.isfinite(t_s + sum(a.tolist()) + sum(b.tolist())):     # NaN/inf propagate through the sum
            return self._reject("imu_nan")
        dt = t_s - self.t_latest_s
        if dt == 0.0 and self._times:
            return self._reject("imu_duplicate")
        if dt <= 0.0:
            return self._reject("imu_out_of_order")
        return True, "ok"

    def _accept_imu(self, t_s, dth, dv, rates=None, load=None) -> None:
        dt = t_s - self.t_latest_s
        if self._last_dt is None and not self._times and not self._ahead and dt > self.cfg.imu_gap_s:
            # the first sample, far after the initial state's epoch (a live vehicle whose init.t_s was left at
            # 0): it starts the time line; the initial state is taken at its stamp, its interval not flown
            self.kf.t_s = self._t0_out = t_s
            self._base = self.kf.snapshot()
            self._last_dt = math.inf
            self.counters["imu_time_origin"] += 1
            self.counters["imu_accepted"] += 1
            self._predict_current()
            return
        if self._last_dt == math.inf:
            self._last_dt = None
        if dt > self.cfg.imu_gap_s and self._last_dt is not None:
            # the new sample covers its own (nominal) interval: rates given, or increments / nominal interval
            w1, f1 = rates if rates is not None else (dth / self._last_dt, dv / self._last_dt)
            self._bridge_gap(t_s, w1, f1)
            dt = t_s - self.t_latest_s
            dth, dv = w1 * dt, f1 * dt
        if self._dirty_from != math.inf:
            self._catch_up()
        self._push(ImuSample(t_s, dt, dth, dv, load))
        self._last_dt = dt
        self.counters["imu_accepted"] += 1
        self._advance(t_s - self.fusion_delay_s)
        if self._times and self._times[self._n_out_of_window] < t_s - self.cfg.reprocess_window_s:
            self._trim()
        self._predict_current()

    def _push(self, imu: ImuSample) -> None:
        """A new sample: fused now (no fusion delay) or buffered ahead of the horizon."""
        self._new.append(imu)
        if self.fusion_delay_s == 0.0:
            self._append_epoch(imu)
        else:
            Q, self._pending_gap_Q = self._pending_gap_Q, None
            self._ahead.append(imu)
            self._ahead_Q.append(Q)

    def _advance(self, t_horizon: float) -> None:
        """Fuse the buffered samples up to the horizon (late events first)."""
        ahead = self._ahead
        if not ahead or ahead[0].t_s > t_horizon + _EPS_S:
            return
        if self._dirty_from != math.inf:
            self._catch_up()
        n = 0
        while n < len(ahead) and ahead[n].t_s <= t_horizon + _EPS_S:
            self._pending_gap_Q = self._ahead_Q[n]
            self._append_epoch(ahead[n])
            n += 1
        del ahead[:n]
        del self._ahead_Q[:n]

    def _predict_current(self) -> None:
        """The state at the newest sample (``current``): the output predictor
        over the samples ahead of the filter's newest epoch."""
        if self._dirty_from != math.inf:
            self._catch_up()
        ep = self._epochs[-1] if self._epochs else None
        anchor = ep.snap if ep is not None else self._base
        if self._ahead:
            pred = self.predictor.step(anchor, self._revision, self._ahead, self._new)
        else:                                     # no lead: the filter's own state (OutputPredictor.step)
            pred = self.predictor.anchored(anchor, self._revision)
        self._new = []
        mode, kinds = self._mode(ep) if ep is not None else (MODE_INITIALIZING, ())
        self.current = CurrentSolution.of_prediction(self.kf, self.predictor, pred, mode, kinds)
        if self.current_log is not None:
            self.current_log.append(self.current)

    def add_measurement(self, meas) -> tuple[bool, str]:
        """Queue an aiding measurement (``meas.t_s`` is its epoch). Late ones
        trigger re-processing from their epoch."""
        kind = meas.kind
        if not is_finite(meas):
            return self._reject(f"{kind}_nan")
        return self._queue(meas, _MEASUREMENT)

    def add_model_update(self, update: ModelUpdate) -> tuple[bool, str]:
        """Queue a model update, applied at ``update.t_s`` (before measurements
        of the same epoch). Invalid updates are rejected and counted."""
        try:
            self.cfg.with_updates(update.fields)
        except ConfigError:
            return self._reject("model_update_invalid")
        return self._queue(update, _MODEL_UPDATE)

    def _queue(self, event, priority: int) -> tuple[bool, str]:
        kind, t = event.kind, event.t_s
        if not math.isfinite(t):
            return self._reject(f"{kind}_nan")
        if self.is_stale(t):
            return self._reject(f"{kind}_stale")
        if t <= self._last_released_t + _tol(self._last_released_t):
            # still applied, but solutions already released did not see it:
            # a delay longer than output_delay_s (live and offline may differ)
            self.counters[f"{kind}_after_release"] += 1
        self._seq += 1
        key = (t, priority, kind, self._seq, event)
        bisect.insort(self._events, key)
        self.counters[f"{kind}_received"] += 1
        if self._times and t <= self._times[-1] + _tol(self._times[-1]):
            j = bisect.bisect_left(self._times, t - _tol(t))
            if t < self._times[-1] - _tol(self._times[-1]):
                self.counters[f"{kind}_late"] += 1
            last = self._epochs[-1]
            if j == len(self._epochs) - 1 and self._at == j and self._dirty_from == math.inf \
                    and (last.last_key is None or key[:4] > last.last_key):
                # it belongs to the latest epoch and sorts after what was applied there: applying it
                # to the current state is what re-processing the epoch would give
                self._apply(last, [key])
            else:
                self._dirty_from = min(self._dirty_from, j)
        return True, "ok"

    # ---- gaps ---------------------------------------------------------------------
    def _bridge_gap(self, t_s: float, w1, f1) -> None:
        """Carry the time line over an IMU gap (see the module docstring): the
        body rates are interpolated linearly between the last sample before
        the gap and the first after it, in steps of the nominal interval; each
        step adds its share of the gap's covariance growth (``_gap_Q``), and
        so does the new sample's own interval."""
        t_start = self.t_latest_s
        last = self._ahead[-1] if self._ahead else self._epochs[-1].imu if self._epochs else self._base.imu_prev
        step_nom = self._last_dt
        t_end = t_s - step_nom
        span = t_end - t_start
        if last is None or span <= 0.0:
            return
        n = min(1000, max(1, int(math.ceil(span / step_nom - 1e-9))))
        h = span / n
        w0, f0 = last.dtheta_b_rad / last.dt_s, last.dvel_b_mps / last.dt_s
        t0_rate, t1_rate = t_start - 0.5 * last.dt_s, t_s - 0.5 * step_nom      # mid-interval epochs of the rates
        self._catch_up()
        for i in range(1, n + 1):
            t_i = t_end if i == n else t_start + i * h
            h_i = t_i - self.t_latest_s
            a = (t_i - 0.5 * h_i - t0_rate) / (t1_rate - t0_rate)
            w, f = w0 + a * (w1 - w0), f0 + a * (f1 - f0)
            self._pending_gap_Q = self._gap_Q(h_i, t_s - t_start)
            self._push(ImuSample(t_i, h_i, w * h_i, f * h_i))
            self.counters["imu_bridge_epochs"] += 1
        self._pending_gap_Q = self._gap_Q(t_s - t_end, t_s - t_start)
        self.counters["imu_gaps"] += 1
        self.counters["imu_gap_total_s"] = round(self.counters["imu_gap_total_s"] + (t_s - t_start), 6)
        self.gaps.append((t_start, t_s))

    def _gap_Q(self, h: float, gap_s: float) -> np.ndarray:
        """Process noise of one bridge step of h seconds in a gap of gap_s:
        white specific-force and rate deviations from the interpolation with
        PSDs q_a = sigma_a^2 gap_s and q_w = sigma_w^2 gap_s, so that at the
        end of the gap the velocity error sigma is sigma_a gap_s and the
        attitude's sigma_w gap_s (the size of a constant deviation), while
        each step's covariance is positive semi-definite (measurements may
        arrive inside the gap): att q_w h, vel q_a h, pos q_a h^3/3,
        pos-vel q_a h^2/2."""
        q_a = self.cfg.gap_accel_sigma_mps2 ** 2 * gap_s
        q_w = math.radians(self.cfg.gap_rate_sigma_deg_per_s) ** 2 * gap_s
        lay = self.cfg.layout
        Q = np.zeros((lay.dim, lay.dim))
        a, v, p = lay.sl("att"), lay.sl("vel"), lay.sl("pos")
        I3 = np.eye(3)
        Q[a, a] = q_w * h * I3
        Q[v, v] = q_a * h * I3
        Q[p, p] = q_a * h**3 / 3.0 * I3
        Q[p, v] = Q[v, p] = q_a * h * h / 2.0 * I3
        return Q

    # ---- processing -----------------------------------------------------------------
    def _catch_up(self) -> None:
        """Re-process the stored epochs from the earliest one a late event touched."""
        if self._dirty_from < len(self._epochs):
            k0 = int(self._dirty_from)
            self._revision += 1
            self.counters["epochs_reprocessed"] += len(self._epochs) - k0
            for k in range(k0, len(self._epochs)):
                self._process_epoch(k, self._epochs[k].imu)
        self._dirty_from = math.inf

    def _append_epoch(self, imu: ImuSample) -> None:
        Q, self._pending_gap_Q = self._pending_gap_Q, None
        self._epochs.append(None if Q is None else _Epoch(imu, None, {}, Q))     # carries the gap's inflation
        self._times.append(imu.t_s)
        self._process_epoch(len(self._epochs) - 1, imu)

    def _process_epoch(self, k: int, imu: ImuSample) -> None:
        prev = self._epochs[k - 1] if k > 0 else None
        kf = self.kf
        if self._at != k - 1:
            kf.restore(prev.snap if prev else self._base)
        old = self._epochs[k]
        t_prev = kf.t_s
        kf.predict(imu)
        extra_Q = None
        if old is not None and old.extra_Q is not None:
            extra_Q = old.extra_Q
            kf.P = kf.P + extra_Q
            kf.P_prior = kf.P
        ep = _Epoch(imu, None, prev.last_accept if prev else self._base_accept, extra_Q)
        self._epochs[k] = ep
        events = self._events
        if events and events[-1][0] > t_prev + _tol(t_prev):
            lo = bisect.bisect_right(events, (t_prev + _tol(t_prev),))
            hi = bisect.bisect_right(events, (imu.t_s + _tol(imu.t_s),))
            events = events[lo:hi]
        else:
            events = ()                           # none in (t_prev, t]: no search
        self._apply(ep, events)
        self._at = k

    def _apply(self, ep: "_Epoch", events) -> None:
        """Apply events (in order) to the filter, which is at epoch ``ep``
        after its predict and any earlier events; then snapshot the epoch."""
        if events:
            self._revision += 1
        for key in events:
            t_m, ev = key[0], key[-1]
            if key[1] == _MODEL_UPDATE:                       # the queue's entry point says what it is
                ev.apply_to(self.kf)
            else:
                if ep.ctx is None:
                    ep.ctx = ModelContext.at(self.kf, ep.imu, self.cfg.antenna_lever_arm_b_m)
                res = self.kf.update(ev.kind, t_m, *self.kf.model(ev, ep.ctx.shifted(t_m - ep.imu.t_s)))
                if res.accepted:
                    ep.last_accept = {**ep.last_accept, (ev.kind, ev.coupling): t_m}
            ep.last_key = key[:4]
        ep.snap = self.kf.snapshot()
        if self.keep_history:
            ep.Phi, ep.P_prior, ep.dx = self.kf.last_Phi, self.kf.P_prior, self.kf.epoch_dx

    def release(self, final: bool = False) -> list[Solution]:
        """Solutions now older than output_delay_s (all of them when final), on
        the output grid t0 + n / output_rate_hz."""
        if final:
            self._advance(math.inf)
        if self._dirty_from != math.inf:
            self._catch_up()
        out = []
        horizon = self.t_latest_s - (0.0 if final else self.cfg.output_delay_s)
        rate = self.cfg.output_rate_hz
        i = self._released
        while i < len(self._epochs):
            t = self._times[i]
            if t > horizon + _tol(horizon):
                break
            if t >= self._t0_out + self._n_out / rate - 1e-6:
                out.append(self._solution(self._epochs[i]))
                self._last_released_t = t
                self._n_out = int(math.floor((t - self._t0_out) * rate + 1e-6)) + 1
            i += 1
        self._released = i
        return out

    def full_history(self) -> list:
        """Every processed epoch so far (needs keep_history=True)."""
        self._advance(math.inf)
        self._catch_up()
        if not self.keep_history:
            raise RuntimeError("FusionEngine(keep_history=True) is needed for the smoother")
        return self.history + self._epochs

    def mode_now(self) -> tuple[int, tuple]:
        """(mode, recently accepted kinds) at the latest epoch."""
        if not self._epochs:
            return MODE_INITIALIZING, ()
        return self._mode(self._epochs[-1])

    # ---- internals ------------------------------------------------------------------
    def _reject(self, reason: str):
        self.counters[f"rejected_{reason}"] += 1
        return False, reason

    def is_stale(self, t_s: float) -> bool:
        """An event at ``t_s`` would be refused as stale (at or before the
        window start): a source can leave such an epoch without side effects."""
        return t_s <= self._window_start_s()

    def _window_start_s(self) -> float:
        """Epoch of the state the window starts from: events at or before it are stale."""
        n = self._n_out_of_window
        return self._times[n - 1] if n else self._base.t_s

    def _trim(self) -> None:
        """Move the window start: epochs older than reprocess_window_s (and
        already released; the latest always stays) leave the window. They are
        dropped from memory _TRIM_CHUNK at a time, which changes nothing
        else: an event at or before the window start is rejected as stale
        either way (``_window_start_s``), so re-processing never reaches them."""
        t_min = self.t_latest_s - self.cfg.reprocess_window_s
        n_drop = self._n_out_of_window
        limit = min(len(self._epochs) - 1, self._released)
        while n_drop < limit and self._times[n_drop] < t_min:
            n_drop += 1
        self._n_out_of_window = n_drop
        if n_drop >= _TRIM_CHUNK:
            self._n_out_of_window = 0
            if self.keep_history:
                self.history.extend(self._epochs[:n_drop])
            self._base = self._epochs[n_drop - 1].snap
            self._base_accept = self._epochs[n_drop - 1].last_accept
            del self._epochs[:n_drop]
            del self._times[:n_drop]
            self._released -= n_drop
            self._at -= n_drop
            if self._dirty_from != math.inf:
                self._dirty_from = max(0, self._dirty_from - n_drop)
            cut = bisect.bisect_right(self._events, (self._base.t_s + _tol(self._base.t_s),))
            del self._events[:cut]

    def _mode(self, ep: _Epoch) -> tuple[int, tuple]:
        """What the solution runs on: the strongest coupling among the sources
        accepted within MODE_WINDOW_S (t <= t_accept + MODE_WINDOW_S; tight >
        loose > other aiding). The answer for one acceptance record holds from
        the last expiry before t to the next one (cached: consecutive epochs
        share it)."""
        if ep.snap.n_updates == 0:
            return MODE_INITIALIZING, ()
        t = ep.imu.t_s
        for c in self._mode_cache or ():            # (None: emptied)
            if c[0] is ep.last_accept and c[1] < t <= c[2]:
                return c[3]
        expiry = {key: t_a + MODE_WINDOW_S for key, t_a in ep.last_accept.items()}
        recent = [key for key, t_end in expiry.items() if t <= t_end]
        if not recent:
            result = MODE_INS_ONLY, ()
        else:
            modes = {_COUPLING_MODE.get(coupling, MODE_AIDED) for _, coupling in recent}
            mode = next(m for m in (MODE_TIGHTLY_COUPLED, MODE_LOOSELY_COUPLED, MODE_AIDED) if m in modes)
            result = mode, tuple(sorted({kind for kind, _ in recent}))
        # two entries: the released epoch (output_delay_s behind) and the newest one (the current-time
        # state) ask in turn (with one entry, each evicted the other's at every change of last_accept)
        self._mode_cache = (self._mode_cache or ())[-1:] + ((
            ep.last_accept, max((e for e in expiry.values() if t > e), default=-math.inf),
            min((e for e in expiry.values() if t <= e), default=math.inf), result),)
        return result

    def _solution(self, ep: _Epoch) -> Solution:
        mode, kinds = self._mode(ep)
        return Solution.of(self.kf, ep.snap, ep.imu, mode, kinds)
