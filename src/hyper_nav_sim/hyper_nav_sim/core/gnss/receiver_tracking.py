"""Receiver-level tracking option of the GNSS simulator (``gnss.raw.tracking:``
block, off by default): between measurement epochs each satellite's channel
runs the 1 kHz loop simulation of :mod:`.tracking` on the Doppler and C/N0 of
:mod:`.signal_env`; its lock is the outcome (mode >= 1: code and Doppler valid;
mode 2: carrier phase lock) instead of :class:`.lock.LockModel`'s criteria.

Configuration (units in the names)::

    tracking:
      mode: unaided | aided          # aided: loops track the residual after the
                                     # navigation-predicted Doppler
      max_channels: 12
      signal: {...}                  # SignalEnvironment.from_dict (antenna, plasma, ...)
      loop: {...}                    # LoopConfig fields overriding the mode's defaults
      speed_uncertainty_mps: 2500.0  # unaided search: Doppler not predictable
      clock_drift_uncertainty_mps: 100.0
      n_parallel: 2046               # cells per dwell (FFT over code; aided: the whole window in one dwell)
      aiding_sigma_vel_mps: 0.05     # aided: predicted-Doppler error (Gauss-Markov)
      aiding_sigma_acc_mps2: 0.001   # growth of that sigma while no fix (INS coasting)
      aiding_tau_s: 20.0
      aiding_k_sigma: 3.0
      aiding_source: model           # aided: 'model' (the Gauss-Markov error above) or 'nav_state'
                                     # (the fusion node's state and covariance, :mod:`.aiding`;
                                     # gnss_node subscribes nav/state; without a fresh state the
                                     # channels run unaided: wide loops, unaided search)
      aiding_max_age_s: 2.0          # nav_state: a held state older than this is stale (the fusion
                                     # node releases its states output_delay_s = 1 s late)
      aiding_accel_sigma_mps2: 0.2   # nav_state: unmodelled acceleration over the state's age

Per epoch (:meth:`ReceiverTracking.step`) the Doppler between epochs is the
cubic Hermite interpolant of the epoch Dopplers and rates, C/N0 is linear.
Outputs per channel: mode, validity (mode >= 1 and the estimated C/N0 above
the loop's drop level: a detection is verified before its code is used),
estimated C/N0, carrier-lock time, code error
[chips] and frequency error [Hz] at the epoch, and the GnssMeasurements
``tracking_flags`` (PR_VALID=1, CP_VALID=2, DOPPLER_VALID=8, AIDED=16).
A new satellite is assumed acquired at first sight (as :class:`.lock.LockModel`).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from hyper_nav_gnss.constants import C_MPS

from hyper_nav_gnss.receiver import acquisition as acq
from hyper_nav_sim.core.gnss.signal_env import SignalEnvironment
from hyper_nav_gnss.receiver.tracking import (
    MODE_FLL, MODE_PLL, P_ACQ_CBIN, P_ACQ_DBIN, S_ACC, S_BI, S_BQ, S_BW, S_CELL, S_CN0E, S_COFF, S_DK, S_DMS,
    S_DSTAT, S_EPS, S_FNCO, S_FOFF, S_HAVEP, S_IC, S_LOCKT, S_MODE, S_MSB, S_MSC, S_NBLK, S_NCOLIM, S_PEN, S_Q, S_QC,
    S_SEARCHT, S_TRUE, S_VEL, ChannelBank, LoopConfig, new_state, track_block,
)

TRACK_PR_VALID, TRACK_CP_VALID, TRACK_DOPPLER_VALID, TRACK_AIDED = 1, 2, 8, 16
DOPPLER_AVG_S = 0.1         # Doppler measurement: the NCO frequency averaged over this interval
_FIELDS = {"mode", "max_channels", "signal", "loop", "speed_uncertainty_mps", "clock_drift_uncertainty_mps",
           "n_parallel", "aiding_sigma_vel_mps", "aiding_sigma_acc_mps2", "aiding_tau_s", "aiding_k_sigma",
           "aiding_source", "aiding_max_age_s", "aiding_accel_sigma_mps2"}


@dataclass
class TrackingConfig:
    mode: str = "unaided"
    max_channels: int = 12
    signal: SignalEnvironment = field(default_factory=SignalEnvironment)
    loop: LoopConfig = field(default_factory=LoopConfig)
    speed_uncertainty_mps: float = 2500.0
    clock_drift_uncertainty_mps: float = 100.0
    n_parallel: float = 2046.0
    aiding_sigma_vel_mps: float = 0.05
    aiding_sigma_acc_mps2: float = 1e-3
    aiding_tau_s: float = 20.0
    aiding_k_sigma: float = 3.0
    aiding_source: str = "model"
    aiding_max_age_s: float = 2.0
    aiding_accel_sigma_mps2: float = 0.2

    @classmethod
    def from_dict(cls, d: dict) -> "TrackingConfig":
        d = dict(d or {})
        bad = set(d) - _FIELDS
        if bad:
            raise ValueError(f"gnss.tracking: unknown field(s) {sorted(bad)}; allowed {sorted(_FIELDS)}")
        mode = d.get("mode", "unaided")
        if mode not in ("unaided", "aided"):
            raise ValueError(f"gnss.tracking.mode: expected 'unaided' or 'aided', got {mode!r}")
        base = LoopConfig() if mode == "unaided" else LoopConfig.aided_default()
        lp = d.get("loop") or {}
        names = {f.name for f in fields(LoopConfig)}
        if not isinstance(lp, dict) or set(lp) - names:
            raise ValueError(f"gnss.tracking.loop: unknown field(s) {sorted(set(lp) - names)}; allowed {sorted(names)}")
        for k, v in lp.items():
            setattr(base, k, v)
        try:
            base.validate()
        except ValueError as e:
            raise ValueError(f"gnss.tracking.loop.{e}") from None
        src = d.get("aiding_source", "model")
        if src not in ("model", "nav_state") or (src == "nav_state" and mode != "aided"):
            raise ValueError(f"gnss.tracking.aiding_source: expected 'model' or 'nav_state' (mode aided), got {src!r}")
        c = cls(mode=mode, signal=SignalEnvironment.from_dict(d.get("signal")), loop=base, aiding_source=src)
        for k in ("max_channels", "speed_uncertainty_mps", "clock_drift_uncertainty_mps", "n_parallel",
                  "aiding_sigma_vel_mps", "aiding_sigma_acc_mps2", "aiding_tau_s", "aiding_k_sigma",
                  "aiding_max_age_s", "aiding_accel_sigma_mps2"):
            if k in d:
                v = d[k]
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or v < 0:
                    raise ValueError(f"gnss.tracking.{k}: expected a finite number >= 0, got {v!r}")
                setattr(c, k, type(getattr(c, k))(v))
        if c.max_channels < 1 or c.aiding_tau_s <= 0 or c.n_parallel < 1:
            raise ValueError("gnss.tracking: max_channels >= 1, n_parallel >= 1 and aiding_tau_s > 0 required")
        return c


@dataclass
class TrackingEpoch:
    mode: np.ndarray
    valid: np.ndarray
    cn0_true_dbhz: np.ndarray
    cn0_est_dbhz: np.ndarray
    lock_time_s: np.ndarray
    code_err_chips: np.ndarray
    freq_err_hz: np.ndarray
    tracking_flags: np.ndarray


class ReceiverTracking:
    """Channel bookkeeping (satellite -> slot) around one channel-state array
    run by :func:`.tracking.track_block` with the aided or the unaided loop
    configuration per slot (``nav_state`` aiding: a slot runs aided while the
    epoch has a prediction for its satellite, unaided otherwise)."""

    def __init__(self, cfg: TrackingConfig, rng: np.random.Generator | None):
        self.cfg = cfg
        self.rng = rng if rng is not None else np.random.default_rng(0)
        n = cfg.max_channels
        self.bank = ChannelBank(cfg.loop, n, np.zeros(n))
        self.external = cfg.aiding_source == "nav_state"
        self.cfg_unaided = LoopConfig() if self.external else cfg.loop
        self.p = {True: self.bank.p, False: self.cfg_unaided.as_array()} if self.external else None
        self.kind = np.full(n, cfg.mode == "aided" and not self.external)       # per slot: aided loops?
        self.slot: dict[str, int] = {}
        self.t_prev = None
        self.prev = {}             # sat -> (f_in, fdot_in, cn0, f_pred or None)
        self.aid_z = {}            # sat -> GM state of the aiding error (standard normal)
        self.t_last_fix = None
        hw = acq.unaided_doppler_halfwidth_hz(cfg.speed_uncertainty_mps, cfg.clock_drift_uncertainty_mps)
        ucfg = self.cfg_unaided
        self.q_unaided = float(acq.search_cells(hw, 511.5, ucfg.acq_doppler_bin_hz, ucfg.acq_code_bin_chips,
                                                cfg.n_parallel))
        if cfg.mode == "unaided" or self.external:
            self.bank.set_search_cells(self.q_unaided)
        self.counts = {"aided_channel_epochs": 0, "unaided_channel_epochs": 0, "switches": 0,
                       "residual_beyond_k_sigma": 0, "residual_beyond_1_sigma": 0}

    def _aiding_sigmas(self, t):
        """(line-of-sight velocity sigma [m/s], range sigma [m]) of the prediction."""
        c = self.cfg
        dt = 0.0 if self.t_last_fix is None else max(0.0, t - self.t_last_fix)
        s_v = np.hypot(c.aiding_sigma_vel_mps, c.aiding_sigma_acc_mps2 * dt)
        return s_v, 30.0 + 0.5 * c.aiding_sigma_acc_mps2 * dt * dt

    def _switch(self, i, to_aided, f_pred_hz):
        """Hand slot i between the aided loops (NCO relative to the prediction)
        and the unaided ones (absolute NCO): the NCO keeps its frequency, the
        integrations restart (their lengths differ), a search restarts."""
        st = self.bank.state[i]
        sign = -1.0 if to_aided else 1.0
        st[S_FNCO] += sign * f_pred_hz
        st[S_VEL] += sign * 2 * np.pi * f_pred_hz
        st[S_ACC] = 0.0
        for col in (S_MSC, S_IC, S_QC, S_HAVEP, S_MSB, S_BI, S_BQ, S_BW):
            st[col] = 0.0
        self.kind[i] = to_aided
        self.counts["switches"] += 1
        if st[S_MODE] == 0:
            p = self.p[bool(to_aided)]
            u = self.rng.random(3)
            for col in (S_CELL, S_DMS, S_DSTAT, S_DK, S_PEN, S_SEARCHT):
                st[col] = 0.0
            st[S_TRUE] = np.floor(u[0] * st[S_Q])
            st[S_FOFF] = (u[1] - 0.5) * p[P_ACQ_DBIN]
            st[S_COFF] = (u[2] - 0.5) * p[P_ACQ_CBIN]

    def step(self, t_s, sat_ids, doppler_hz, doppler_rate_hzps, el_rad, az_rad, C_b_n, alt_m=None, mach=None,
             carrier_hz=1575.42e6, aid=None) -> TrackingEpoch:
        """One epoch. ``aid`` (``nav_state`` aiding only): None (no fresh
        prediction: unaided) or (doppler residual [Hz], line-of-sight velocity
        sigma [m/s], range sigma [m]) per satellite (:mod:`.aiding`)."""
        c = self.cfg
        cn0 = c.signal.cn0_dbhz(t_s, el_rad, az_rad, C_b_n, alt_m, mach)
        f = np.asarray(doppler_hz, float)
        fd = np.asarray(doppler_rate_hzps, float)
        lam = C_MPS / np.asarray(carrier_hz, float) * np.ones(len(sat_ids))
        f_pred = None
        if self.external:
            if aid is not None:
                res, s_v, s_r = (np.asarray(a, float) for a in aid)
                f_in, fd_in = np.where(np.isfinite(res), res, f), np.where(np.isfinite(res), 0.0, fd)
                f_pred = np.where(np.isfinite(res), f - res, np.nan)
                fdw, ccw = acq.aided_halfwidths(np.nan_to_num(s_v), np.nan_to_num(s_r), c.aiding_k_sigma)
                q_aid = acq.search_cells(fdw, ccw, c.loop.acq_doppler_bin_hz, c.loop.acq_code_bin_chips,
                                         c.n_parallel)
                # the simulator's own check of the prediction (the receiver cannot see it): residuals
                # outside the loop's bound (k sigma), and beyond 1 sigma, per channel-epoch
                ok = np.isfinite(res)
                self.counts["residual_beyond_k_sigma"] += int(np.sum(np.abs(res[ok]) > fdw[ok]))
                self.counts["residual_beyond_1_sigma"] += int(np.sum(np.abs(res[ok]) * c.aiding_k_sigma > fdw[ok]))
            else:
                f_in, fd_in = f, fd
            aided_now = np.zeros(len(sat_ids), bool) if f_pred is None else np.isfinite(f_pred)
        elif c.mode == "aided":
            s_v, s_r = self._aiding_sigmas(t_s)
            dt = 0.0 if self.t_prev is None else t_s - self.t_prev
            phi = np.exp(-dt / c.aiding_tau_s)
            err = np.empty(len(sat_ids))
            for k, s in enumerate(sat_ids):
                z = self.aid_z.get(s)
                w = self.rng.standard_normal()
                z = w if z is None else phi * z + np.sqrt(1 - phi * phi) * w
                self.aid_z[s] = z
                err[k] = s_v * z / lam[k]
            f_in, fd_in = -err, np.zeros_like(err)
            fdw, ccw = acq.aided_halfwidths(s_v, s_r, c.aiding_k_sigma)
            self.bank.set_search_cells(acq.search_cells(fdw, ccw, c.loop.acq_doppler_bin_hz,
                                                        c.loop.acq_code_bin_chips, c.n_parallel))
        else:
            f_in, fd_in = f, fd
        # channel allocation: new satellites take free slots, assumed acquired at first sight
        for s in [s for s in self.slot if s not in sat_ids]:
            del self.slot[s]
            self.prev.pop(s, None)
            self.aid_z.pop(s, None)
        free = [i for i in range(c.max_channels) if i not in self.slot.values()]
        for k, s in enumerate(sat_ids):
            if s not in self.slot and free:
                i = free.pop(0)
                self.slot[s] = i
                if self.external:
                    self.kind[i] = aided_now[k]
                    self.bank.state[i, S_Q] = q_aid[k] if aided_now[k] else self.q_unaided
                self.bank.state[i] = new_state(1, f_in[k], fd_in[k], self.bank.state[i, S_Q], cn0[k])[0]
        if self.external:          # aided <-> unaided per slot; search windows per slot
            for k, s in enumerate(sat_ids):
                i = self.slot.get(s)
                if i is None:
                    continue
                if bool(self.kind[i]) != bool(aided_now[k]):
                    fp = f_pred[k] if aided_now[k] else self.prev.get(s, (0, 0, 0, np.nan))[3]
                    self._switch(i, bool(aided_now[k]), 0.0 if not np.isfinite(fp) else fp)
                    self.prev.pop(s, None)          # the interval starts from this epoch's input
                self.bank.state[i, S_Q] = max(1.0, np.ceil(q_aid[k])) if aided_now[k] else self.q_unaided
                if aided_now[k]:        # the loop's correction bounded to k sigma of this prediction
                    self.bank.state[i, S_NCOLIM] = min(fdw[k], 0.9 * 0.25 / c.loop.t_coh_s)
                self.counts["aided_channel_epochs" if aided_now[k] else "unaided_channel_epochs"] += 1
        if self.external and f_pred is not None and self.t_prev is not None and t_s > self.t_prev:
            # aided residual between epochs: slope = the secant from the previous epoch (its prediction is
            # a fresh state's, not a trajectory with a rate; a zero slope made every epoch a jerk)
            fd_in = fd_in.copy()
            for k, s in enumerate(sat_ids):
                pv = self.prev.get(s)
                if aided_now[k] and pv is not None and pv[3] is not None and np.isfinite(pv[3]):
                    fd_in[k] = (f_in[k] - pv[0]) / (t_s - self.t_prev)
        n = c.max_channels
        # Doppler as the receiver measures it: the NCO frequency averaged over the last DOPPLER_AVG_S
        # (the instantaneous NCO carries the loop's proportional kick on each discriminator output)
        df_avg = np.zeros(n)
        n_avg = 1
        if self.t_prev is not None and t_s > self.t_prev:
            n_avg = max(1, min(int(round((t_s - self.t_prev) * 1000.0)), int(round(DOPPLER_AVG_S * 1000.0))))
        if self.t_prev is not None and t_s > self.t_prev:
            n_ms = int(round((t_s - self.t_prev) * 1000.0))
            tau = (np.arange(1, n_ms + 1) / n_ms)[:, None]
            F = np.zeros((n_ms, n))
            CN = np.full((n_ms, n), -50.0)        # unused slots: no signal
            h = t_s - self.t_prev
            for k, s in enumerate(sat_ids):
                i = self.slot.get(s)
                if i is None:
                    continue
                f1, fd1 = f_in[k], fd_in[k]
                f0, fd0, c0, _ = self.prev.get(s, (f1, fd1, cn0[k], None))
                x = tau[:, 0]
                h00, h10, h01, h11 = 2 * x**3 - 3 * x**2 + 1, x**3 - 2 * x**2 + x, -2 * x**3 + 3 * x**2, x**3 - x**2
                F[:, i] = h00 * f0 + h10 * h * fd0 + h01 * f1 + h11 * h * fd1
                CN[:, i] = c0 + (cn0[k] - c0) * x
            if not self.external:
                o = self.bank.run(F, CN, self.rng)
                df_avg[:] = o.freq_err_hz[-n_avg:].mean(axis=0)
            else:
                noise = self.rng.standard_normal((n_ms, n, 3))
                unif = self.rng.random((n_ms, n, 3))
                for kind in (True, False):
                    idx = np.flatnonzero(self.kind == kind)
                    if idx.size:
                        sub = np.ascontiguousarray(self.bank.state[idx])
                        outs = [np.empty((n_ms, idx.size)) for _ in range(5)]
                        track_block(np.ascontiguousarray(F[:, idx]), np.ascontiguousarray(CN[:, idx]),
                                    np.ascontiguousarray(noise[:, idx]), np.ascontiguousarray(unif[:, idx]),
                                    self.p[kind], sub, *outs)
                        self.bank.state[idx] = sub
                        df_avg[idx] = outs[2][-n_avg:].mean(axis=0)
        for k, s in enumerate(sat_ids):
            self.prev[s] = (f_in[k], fd_in[k], cn0[k], None if f_pred is None else f_pred[k])
        self.t_prev = t_s
        st = self.bank.state
        idx = np.array([self.slot.get(s, -1) for s in sat_ids], int)
        ok = idx >= 0
        ii = np.where(ok, idx, 0)
        mode = np.where(ok, st[ii, S_MODE], 0).astype(int)
        cn0_est = np.where(ok, st[ii, S_CN0E], np.nan)
        aided_ch = np.where(ok, self.kind[ii], False) if self.external else np.full(len(sat_ids), c.mode == "aided")
        drop = np.where(aided_ch, c.loop.cn0_drop_dbhz, self.cfg_unaided.cn0_drop_dbhz)
        # code/Doppler valid: a tracking mode whose C/N0 estimate confirms the signal (above the drop level)
        settle = np.where(aided_ch, c.loop.code_settle_s, self.cfg_unaided.code_settle_s)
        settled = np.where(ok, st[ii, S_NBLK], 0.0) * 0.02 >= settle - 1e-9     # DLL settled since the handover
        valid = (mode >= MODE_FLL) & (np.nan_to_num(cn0_est, nan=-99.0) >= drop) & settled
        flags = np.zeros(len(sat_ids), np.uint8)
        flags |= np.where(valid, TRACK_PR_VALID | TRACK_DOPPLER_VALID, 0).astype(np.uint8)
        flags |= np.where(valid & (mode == MODE_PLL), TRACK_CP_VALID, 0).astype(np.uint8)
        flags |= np.where(aided_ch, TRACK_AIDED, 0).astype(np.uint8)
        return TrackingEpoch(mode, valid, cn0, cn0_est, np.where(ok, st[ii, S_LOCKT], 0.0),
                             np.where(ok & (mode >= 1), st[ii, S_EPS], 0.0),
                             np.where(ok & (mode >= 1), df_avg[ii], 0.0), flags)

    def common_mode_hz(self, min_channels=3):
        """Median NCO correction [Hz] of the aided channels in phase lock (what all
        of them see in common: the receiver clock-drift error of the prediction),
        or None with fewer than ``min_channels``."""
        if not self.external:
            return None
        st = self.bank.state
        idx = [i for i in self.slot.values() if self.kind[i] and st[i, S_MODE] == MODE_PLL]
        return float(np.median(st[idx, S_FNCO])) if len(idx) >= min_channels else None

    def shift_aided(self, df_hz):
        """The prediction moved by df_hz (a new clock-drift estimate): the aided
        channels' NCOs, relative to it, move by -df_hz."""
        for i in self.slot.values():
            if self.kind[i]:
                self.bank.state[i, S_FNCO] -= df_hz
                self.bank.state[i, S_VEL] -= 2 * np.pi * df_hz

    def note_fix(self, t_s, has_fix: bool):
        """The receiver's PVT state: the aiding covariance grows from the last fix."""
        if has_fix or self.t_last_fix is None:
            self.t_last_fix = t_s
