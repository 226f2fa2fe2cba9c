"""Lock-out monitor of the innovation gate: a source the gate refuses for
too long is taken back by inflating the covariance (PX4 EKF2's
innovation-consistency timeout, as a covariance inflation).

The anti-pattern it guards against (STYLE, "A gate that can lock the filter
out for good"): after the solution drifts with an optimistic covariance
(an IMU configured quieter than it is, a vibrating platform), every correct
fix looks like an outlier and is refused; the filter then runs on the IMU
alone while being fed centimetre fixes. PX4 EKF2 resets position/velocity to
the GNSS after ``EKF2_*`` fusion timeouts (``reset_timeout_max``) and raises a
fault flag; robot_localization reports rejection rates per sensor.

The rule (per measurement kind, evaluated at each gated update):

* a *run* is the sequence of consecutive gate rejections of one kind since
  its last accepted update (an accepted update ends the run);
* the source is *locked out* when its run holds at least
  ``lockout_min_rejections`` rejections AND has lasted at least
  ``lockout_timeout_s`` of measurement time (the source kept arriving and
  was refused all along: PX4's timeout rule);
* recovery (``lockout_recovery: inflate``): the variances of the nav
  blocks the measurement observes (att / vel / pos, those whose share of
  H P H^T is at least ``OBSERVED_SHARE`` of the largest share) are scaled by
  one factor k >= 1, the smallest that brings the refused innovation's NIS
  per degree of freedom down to ``lockout_target_nis_per_dof`` (1: the
  innovation at its expected size; a very small value approaches a reset of
  the observed states to the measurement); every other state's variance is
  scaled by min(k, P0_ii / P_ii) (at least 1): the drift that caused the
  lock-out (attitude, biases) is made uncertain again, but never more than
  at the start (P0: the configured initial covariance). The scaling is the
  congruence P <- T P T with T diagonal (the square roots of those
  factors), which keeps P positive semi-definite and its correlations. The
  measurement is then applied through the ordinary gated update; the run
  ends.

Measured on the synthetic lock-out (``test/core/test_lockout.py``: the
default flight, 120 s, an IMU of 3 deg/sqrt(h), 1000 ug/sqrt(Hz) configured
100x quieter, 2 cm / 2 cm/s fixes at 10 Hz; horizontal RMS after 10 s,
gated share of gnss_pos): no recovery 173 m, 89 %; observed blocks only
(5 s) 0.98 m, 64 %; all nav blocks (5 s) 0.64 m, 53 %; observed + the rest
up to P0 (5 s) 0.43 m, 37 %, (2 s) 0.098 m, 18 %, (1 s) 0.047 m, 8 %;
the target NIS/dof 0.01 instead of 1 (observed only, 5 s) changed little
(1.02 m). Chosen: observed + the rest up to P0, 1 s and 5 refusals.
* no recovery when the nav states cannot explain the innovation: if even
  k = 1e12 leaves its NIS above the target (a residual in the states the
  inflation does not touch: receiver clock, range biases, or a source
  inconsistent in itself, as virtual pseudoranges extrapolated through a
  lock loss), ``inflation`` returns k = inf and the filter keeps refusing
  the source; the run starts afresh, so the next attempt waits another
  timeout. Counted per kind (``unexplained``). Found on seed 004's virtual
  pseudoranges (case b of the blackout study, 16 dof, residuals of 343 m):
  two capped inflations took the position variance to 2.4e23 m^2 and the
  state to NaN;
* no recovery from a measurement that does not determine a whole
  position or velocity block it observes, beside the receiver clock it
  observes too (``determines``: one to three satellites' pseudoranges
  and rates, a height, a horizontal fix): re-anchoring a block to such a
  measurement trusts a gross error of its own, which nothing in the
  epoch can show. Found on the aided-tracking blackout study (case
  'virtual', 10 seeds): near the sheath's end a one-satellite epoch
  (pseudorange 259 m and rate 134 m/s off, sigmas 0.11 m and 0.05 m/s)
  was fitted by k = 2.4e9 and the solution left by 26 km (seed 9), a
  three-satellite one (347 m off) by k = 2e5 and 4.3 km (seed 3); with
  this rule the lock-out waits for an epoch that determines the blocks.
  Counted as ``unexplained`` too;
* innovations beyond ``FAR_SIGMA`` of the measurement's own noise are
  counted per kind (``far``), accepted or not, for the verdict's
  'departure' rule;
* every recovery is counted per kind (``recoveries``), with the epoch of
  the last one and the inflation factor; the fusion node reports them on
  ``/diagnostics`` (``<kind>_lockout_recoveries``) and the verdict rules
  (``hyper_nav_workbench.core.verdict_rules``) name them.

The monitor's state is immutable (a new ``Watch`` per change) and travels in
the filter snapshot, so re-processing a late event gives the same recoveries.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

FAR_SIGMA = 5.0                 # an innovation beyond this many of the measurement's own sigmas is 'far'
OBSERVED_SHARE = 1e-3           # a nav block is observed when its share of tr(H P H^T) is at least this
_NAV_BLOCKS = ("att", "vel", "pos")
_K_MAX = 1e12                   # inflation factor cap (a sigma x 1e6)


class Watch(NamedTuple):
    """One kind's record: the current run of rejections and the recoveries."""
    run: int = 0                       # consecutive gate rejections since the last accepted update
    t_run_start_s: float = math.nan    # epoch of the run's first rejection
    recoveries: int = 0
    t_last_recovery_s: float = math.nan
    last_factor: float = math.nan      # the last inflation factor k
    far: int = 0                       # innovations (accepted or not) with r^T R^-1 r / dof > FAR_SIGMA^2
    unexplained: int = 0               # lock-outs the nav states could not explain (no recovery made)


class LockoutRule(NamedTuple):
    timeout_s: float
    min_rejections: int
    recovery: str                      # "inflate" or "off"
    target_nis_per_dof: float

    @classmethod
    def of(cls, cfg) -> "LockoutRule":
        return cls(float(cfg.lockout_timeout_s), int(cfg.lockout_min_rejections), str(cfg.lockout_recovery),
                   float(cfg.lockout_target_nis_per_dof))

    def describe(self) -> str:
        if self.recovery == "off":
            return "lock-out recovery off"
        return (f"a source refused by the gate {self.min_rejections} times in a row over >= {self.timeout_s:g} s "
                f"without an accepted update is taken back: P of the observed att/vel/pos blocks scaled so its "
                f"NIS/dof = {self.target_nis_per_dof:g}, then the update applied")


def accepted(w: Watch) -> Watch:
    """An accepted update ends the run (the same object when there is none: nothing to copy)."""
    return w._replace(run=0, t_run_start_s=math.nan) if w.run else w


def gated(w: Watch, t_s: float) -> Watch:
    return w._replace(run=w.run + 1, t_run_start_s=t_s if w.run == 0 else w.t_run_start_s)


def is_far(residual: np.ndarray, R: np.ndarray) -> bool:
    """The innovation is beyond FAR_SIGMA of the measurement's own noise
    (r^T R^-1 r / dof > FAR_SIGMA^2): the solution departs from the source."""
    from .fast.update import innovation_q
    try:
        q = float(innovation_q(np.ascontiguousarray(residual, dtype=float), np.ascontiguousarray(R, dtype=float)))
    except np.linalg.LinAlgError:
        return False
    return q > FAR_SIGMA * FAR_SIGMA * len(residual)


def locked_out(w: Watch, t_s: float, rule: LockoutRule) -> bool:
    """The rule of the module docstring, after ``gated`` counted this rejection."""
    return rule.recovery != "off" and w.run >= rule.min_rejections and t_s - w.t_run_start_s >= rule.timeout_s


def unexplained(w: Watch) -> Watch:
    """A lock-out the nav states cannot explain: no recovery; the run starts afresh."""
    return w._replace(run=0, t_run_start_s=math.nan, unexplained=w.unexplained + 1)


def recovered(w: Watch, t_s: float, k: float) -> Watch:
    return w._replace(recoveries=w.recoveries + 1, t_last_recovery_s=t_s, last_factor=float(k))


CLOCK_BLOCKS = ("clk", "isb")  # receiver clock and inter-system biases: observed by every range alike


def determines(H: np.ndarray, layout, states: np.ndarray) -> bool:
    """Whether the measurement determines in full every position or
    velocity block among the observed ``states``, beside the receiver clock
    it observes too: rank(H over block + clock) - rank(H over clock) = 3, as
    a recovery that re-anchors the block needs (module docstring). Three
    satellites' pseudoranges do not determine the position with the clock
    unknown; four do; a position fix does (with or without a lever arm)."""
    chosen = set(np.asarray(states).tolist())
    clock = [i for name in CLOCK_BLOCKS if layout.has(name) for i in range(layout.sl(name).start,
                                                                          layout.sl(name).stop)
             if np.any(H[:, i] != 0.0)]
    r_clock = np.linalg.matrix_rank(H[:, clock]) if clock else 0
    for name in ("pos", "vel"):
        s = layout.sl(name)
        if s.start in chosen:
            cols = list(range(s.start, s.stop)) + clock
            if np.linalg.matrix_rank(H[:, cols]) - r_clock < s.stop - s.start:
                return False
    return True


def observed_states(P: np.ndarray, H: np.ndarray, layout) -> np.ndarray:
    """Indices of the nav blocks (att, vel, pos) the measurement observes
    (share of tr(H P H^T) >= OBSERVED_SHARE of the largest block's)."""
    shares, idx = [], []
    for name in _NAV_BLOCKS:
        s = layout.sl(name)
        Hb = H[:, s]
        shares.append(float(np.trace(Hb @ P[s, s] @ Hb.T)))
        idx.append(np.arange(s.start, s.stop))
    top = max(shares)
    if not top > 0.0:
        return np.zeros(0, int)
    return np.concatenate([i for sh, i in zip(shares, idx) if sh >= OBSERVED_SHARE * top])


def _scaled(P: np.ndarray, states: np.ndarray, k: float, room: np.ndarray | None = None) -> np.ndarray:
    """T P T: variance factors k on ``states``, min(k, room) >= 1 on the others (room = P0_ii / P_ii)."""
    f = np.ones(len(P)) if room is None else np.clip(room, 1.0, k)
    f[states] = k
    t = np.sqrt(f)
    out = P * np.outer(t, t)
    return 0.5 * (out + out.T)


def _nis(P, H, R, r) -> float:
    S = H @ P @ H.T + R
    try:
        return float(r @ np.linalg.solve(0.5 * (S + S.T), r))
    except np.linalg.LinAlgError:
        return math.inf


def inflation(P: np.ndarray, H: np.ndarray, R: np.ndarray, residual: np.ndarray, layout,
              target_nis_per_dof: float, P0_diag: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """(inflated P, k): the smallest k in [1, 1e12] (bisection on log k, the
    NIS decreases monotonically with k) for which the NIS of ``residual`` is
    at most ``target_nis_per_dof`` x dof; k on the observed nav states, the
    others up to their ``P0_diag`` (module docstring; None: the others kept).
    (P, inf) when no k up to 1e12 does: the nav states cannot explain the
    innovation (or the measurement does not determine a position or velocity
    block it observes: :func:`determines`), and no recovery is made."""
    H = np.asarray(H, float)
    r = np.asarray(residual, float)
    states = observed_states(P, H, layout)
    if len(states) == 0:
        return P, 1.0
    if not determines(H, layout, states):
        return P, math.inf
    room = None if P0_diag is None else np.asarray(P0_diag, float) / np.maximum(np.diag(P), 1e-300)
    target = target_nis_per_dof * len(r)
    if _nis(P, H, R, r) <= target:
        return P, 1.0
    lo, hi = 0.0, math.log(_K_MAX)
    if not _nis(_scaled(P, states, _K_MAX, room), H, R, r) <= target:     # (NaN too)
        return P, math.inf
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if _nis(_scaled(P, states, math.exp(mid), room), H, R, r) > target:
            lo = mid
        else:
            hi = mid
    k = math.exp(hi)
    return _scaled(P, states, k, room), k
