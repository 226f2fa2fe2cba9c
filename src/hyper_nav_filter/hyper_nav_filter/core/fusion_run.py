"""The fusion engine's common case in compiled form: a run of IMU samples
given as mean rates (``FusionEngine.add_imu_rates``), in order, with no
event pending inside it.

``add_imu_rates_run(engine, stamps, rates, forces, rows)`` feeds the samples
``rows`` of the arrays to the engine and returns how many it took. While the
engine is in the common case (the filter at the latest epoch, nothing late to
re-process, the ENU compiled predict with no IMU pre-processing, no
nominally propagated block and no rate-proportional gyro noise, no history
kept for the smoother), the samples go through one compiled call
(``core.fast.enu_run.predict_run``: the per-sample checks, the increments
and ``core.fast.enu.predict`` itself, the function the per-sample path
calls) up to the first one the engine must see on its own: a sample whose
interval holds a queued event (a GNSS fix, a model update), a sample to
reject (NaN, duplicate, out of order) or one after a gap. The run's epochs
are then stored as ``_process_epoch`` stores them (an ``ImuSample``, a
``FilterSnapshot`` and an ``_Epoch`` each; the window trimmed once), so
everything after (late events and their re-processing, release, the
smoother's absence) is the engine's own code on the same objects, and the
results are the per-sample path's bit for bit (``test_fusion_run``). The
sample it stopped at, and any sample outside the common case, goes through
``add_imu_rates``, where the Python engine takes over.

Measured on the peer-format set (672,399 epochs, 21 states, 200 Hz, 1 Hz
fixes): see ``docs/offline_speed.md``.

Per-sample outputs: runs are taken only with no fusion horizon
(``fusion_delay_s`` 0), where the current-time state at a sample is the
filter's own state there (``core.output_predictor``: no lead); the loop in
``_store`` forms it per epoch with the engine's ``_predict_current`` when
the engine keeps the stream (``current_log``), else once at the run's end,
so ``current`` and the log are the per-sample path's. With a horizon the
samples go one by one (the predictor runs over the lead). A further
per-sample consumer is called there too (``engine.on_epoch``, when the
engine has one).
"""
from __future__ import annotations

import bisect
import math

import numpy as np

from .eskf import FilterSnapshot
from .fast import enu_run
from .fusion import _EPS_S, CurrentSolution, FusionEngine, _Epoch
from .nav_state import ImuSample
from .output_predictor import Predicted

MIN_RUN = 16         # shorter runs go sample by sample: the compiled call's fixed cost (argument checks,
                     # the epoch array) is a few epochs' (default rates, 4-sample runs: 37-39 us per epoch
                     # through runs against 33-36 per sample, CPU, same run)


def static_ok(eng: FusionEngine) -> bool:
    """True when the engine's filter can take compiled runs at all: the ENU
    compiled predict, no IMU pre-processing (lever-arm modes), no nominally
    propagated block, no rate-proportional gyro noise, no history for the
    smoother, and a re-processing window longer than the output delay plus
    a gap (so that trimming the window once per run leaves it where trimming
    per sample does)."""
    kf = eng.kf
    cfg = kf.cfg
    return (kf.fast and kf.frame.compiled_runs and not kf._preprocessors and not kf._propagated
            and cfg.gyro_rate_error_pct <= 0.0 and not eng.keep_history
            and cfg.output_delay_s + cfg.imu_gap_s < cfg.reprocess_window_s)


def common_case(eng: FusionEngine) -> bool:
    """True when the next samples may go through the compiled run: ``static_ok``
    for the configuration in force, the filter at the latest epoch, nothing
    late to re-process, no gap being bridged, an earlier sample seen, no fusion
    horizon (``fusion_delay_s`` 0: samples are fused as they come, and the
    current-time state is the filter's own, ``core.output_predictor``)."""
    return (eng._pending_gap_Q is None and eng._dirty_from == math.inf and eng._at == len(eng._epochs) - 1
            and eng._last_dt is not None and eng.fusion_delay_s == 0.0 and not eng._ahead and static_ok(eng))


def next_event_after(eng: FusionEngine, t_s: float) -> float:
    """Time of the first queued event after t_s + _EPS_S (inf: none)."""
    ev = eng._events
    if not ev or ev[-1][0] <= t_s + _EPS_S:
        return math.inf
    k = bisect.bisect_right(ev, (t_s + _EPS_S,))
    return ev[k][0] if k < len(ev) else math.inf


def add_imu_rates_run(eng: FusionEngine, stamps: np.ndarray, rates: np.ndarray, forces: np.ndarray,
                      rows: np.ndarray) -> int:
    """Feed samples ``rows`` (int64) of ``stamps`` (s), ``rates`` (n, 3) rad/s
    and ``forces`` (n, 3) m/s^2 through the compiled run while the engine is
    in the common case; returns how many were taken (the caller feeds the
    rest, from that one on, through ``add_imu_rates``)."""
    if len(rows) < MIN_RUN or not common_case(eng):
        return 0
    kf = eng.kf
    t0 = eng.t_latest_s
    t_event = next_event_after(eng, t0)
    if not stamps[rows[0]] + _EPS_S < t_event:      # the first sample's interval holds an event
        return 0
    prev = kf.imu_prev
    if prev is None:
        pdth, pdv, pdt, has_prev = np.zeros(3), np.zeros(3), 1.0, False
    else:
        pdth, pdv = np.ascontiguousarray(prev.dtheta_b_rad, float), np.ascontiguousarray(prev.dvel_b_mps, float)
        pdt, has_prev = float(prev.dt_s), True
    m = len(rows)
    n = kf.P.shape[0]
    nx = len(kf.x_nav)
    E = np.empty((m, nx + 8))                  # rows stay referenced by the epochs (views)
    if eng.current_log is not None:            # every epoch's P stays referenced (the log): the epochs take views
        PS = np.empty((m, n, n))
    else:                                      # copied out per epoch: one buffer per engine, reused
        PS = getattr(eng, "_run_P_buffer", None)
        if PS is None or PS.shape[0] < m or PS.shape[1] != n:
            PS = np.empty((max(m, 256), n, n))
            eng._run_P_buffer = PS
    k, _, Phi = enu_run.predict_run(kf.x_nav, kf.values, kf.P, float(t0), pdth, pdv, pdt, has_prev, stamps, rates,
                                    forces, rows, t_event, float(kf.cfg.imu_gap_s), *kf.sys.fast_args, E, PS)
    if k:
        _store(eng, k, E, PS, nx, Phi)
    return k


def _store(eng: FusionEngine, k: int, E, PS, nx: int, Phi) -> None:
    """The run's first k epochs into the engine as ``_process_epoch`` leaves them."""
    kf = eng.kf
    epochs, times = eng._epochs, eng._times
    last_accept = epochs[-1].last_accept if epochs else eng._base_accept
    vals, cfg, nu, nr, nis, stats, watch = kf.values, kf.cfg, kf.n_updates, kf.n_rejected, kf.last_nis, kf.stats, \
        kf.watch
    new_imu, new_snap, new_ep = tuple.__new__, tuple.__new__, _Epoch
    on_epoch = getattr(eng, "on_epoch", None)
    # the current-time state per sample: with no fusion horizon (common_case) it is the filter's state at the
    # epoch just stored, as the per-sample path's _predict_current forms it (OutputPredictor.anchored, no lead:
    # the same Predicted and CurrentSolution, the predictor re-anchored once for the run below)
    log = eng.current_log
    share = log is not None                       # the log keeps every P: views of this run's buffer
    mode_of, rev, new_pred, new_cur = eng._mode, eng._revision, tuple.__new__, CurrentSolution.of_prediction
    predictor = eng.predictor
    imu = snap = None
    X, DTH, DV = E[:k, :nx], E[:k, nx:nx + 3], E[:k, nx + 3:nx + 6]
    for j, (t, dt) in enumerate(zip(E[:k, nx + 6].tolist(), E[:k, nx + 7].tolist())):
        imu = new_imu(ImuSample, (t, dt, DTH[j], DV[j], None))
        x = X[j]
        snap = new_snap(FilterSnapshot, (t, x, vals, PS[j] if share else PS[j].copy(), imu, cfg, nu, nr, nis,
                                         stats, watch))
        ep = new_ep(imu, snap, last_accept)
        epochs.append(ep)
        times.append(t)
        if share:
            mode, kinds = mode_of(ep)
            log.append(new_cur(kf, predictor, new_pred(Predicted, (t, x, vals, imu, snap)), mode, kinds))
        if on_epoch is not None:                  # a per-sample consumer
            on_epoch(imu, snap)
    kf.t_s, kf.x_nav, kf.P, kf.imu_prev = snap.t_s, snap.x_nav, snap.P, imu
    kf.last_Phi, kf.P_prior, kf.epoch_dx = Phi, snap.P, None
    eng._at = len(epochs) - 1
    eng._last_dt = imu.dt_s
    eng.counters["imu_accepted"] += k
    if times[eng._n_out_of_window] < imu.t_s - cfg.reprocess_window_s:
        eng._trim()
    if share:                                     # the predictor at the run's last epoch, as k steps leave it
        predictor.anchored(snap, rev, count=k)
        eng.current, eng._new = log[-1], []
    else:
        eng._predict_current()                    # ``current`` at the run's last sample
