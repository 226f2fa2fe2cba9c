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

from . import acquisition as acq
from .signal_env import SignalEnvironment
from .tracking import (MODE_FLL, MODE_PLL, S_CN0E, S_EPS, S_FNCO, S_LOCKT, S_MODE, S_Q, ChannelBank, LoopConfig,
                       new_state)

TRACK_PR_VALID, TRACK_CP_VALID, TRACK_DOPPLER_VALID, TRACK_AIDED = 1, 2, 8, 16
_FIELDS = {"mode", "max_channels", "signal", "loop", "speed_uncertainty_mps", "clock_drift_uncertainty_mps",
           "n_parallel", "aiding_sigma_vel_mps", "aiding_sigma_acc_mps2", "aiding_tau_s", "aiding_k_sigma"}


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
        c = cls(mode=mode, signal=SignalEnvironment.from_dict(d.get("signal")), loop=base)
        for k in ("max_channels", "speed_uncertainty_mps", "clock_drift_uncertainty_mps", "n_parallel",
                  "aiding_sigma_vel_mps", "aiding_sigma_acc_mps2", "aiding_tau_s", "aiding_k_sigma"):
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
    """Channel bookkeeping (satellite -> slot) around one :class:`.tracking.ChannelBank`."""

    def __init__(self, cfg: TrackingConfig, rng: np.random.Generator | None):
        self.cfg = cfg
        self.rng = rng if rng is not None else np.random.default_rng(0)
        n = cfg.max_channels
        self.bank = ChannelBank(cfg.loop, n, np.zeros(n))
        self.slot: dict[str, int] = {}
        self.t_prev = None
        self.prev = {}             # sat -> (f_in, fdot_in, cn0)
        self.aid_z = {}            # sat -> GM state of the aiding error (standard normal)
        self.t_last_fix = None
        if cfg.mode == "unaided":
            hw = acq.unaided_doppler_halfwidth_hz(cfg.speed_uncertainty_mps, cfg.clock_drift_uncertainty_mps)
            self.bank.set_search_cells(acq.search_cells(hw, 511.5, cfg.loop.acq_doppler_bin_hz,
                                                        cfg.loop.acq_code_bin_chips, cfg.n_parallel))

    def _aiding_sigmas(self, t):
        """(line-of-sight velocity sigma [m/s], range sigma [m]) of the prediction."""
        c = self.cfg
        dt = 0.0 if self.t_last_fix is None else max(0.0, t - self.t_last_fix)
        s_v = np.hypot(c.aiding_sigma_vel_mps, c.aiding_sigma_acc_mps2 * dt)
        return s_v, 30.0 + 0.5 * c.aiding_sigma_acc_mps2 * dt * dt

    def step(self, t_s, sat_ids, doppler_hz, doppler_rate_hzps, el_rad, az_rad, C_b_n, alt_m=None, mach=None,
             carrier_hz=1575.42e6) -> TrackingEpoch:
        c = self.cfg
        cn0 = c.signal.cn0_dbhz(t_s, el_rad, az_rad, C_b_n, alt_m, mach)
        f = np.asarray(doppler_hz, float)
        fd = np.asarray(doppler_rate_hzps, float)
        aided = c.mode == "aided"
        lam = 299792458.0 / np.asarray(carrier_hz, float) * np.ones(len(sat_ids))
        if aided:
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
                self.bank.state[i] = new_state(1, f_in[k], fd_in[k], self.bank.state[i, S_Q], cn0[k])[0]
        n = c.max_channels
        if self.t_prev is not None and t_s > self.t_prev:
            n_ms = int(round((t_s - self.t_prev) * 1000.0))
            tau = (np.arange(1, n_ms + 1) / n_ms)[:, None]
            F = np.zeros((n_ms, n))
            CN = np.full((n_ms, n), -50.0)        # unused slots: no signal
            h = t_s - self.t_prev
            for k, s in enumerate(sat_ids):
                i = self.slot.get(s)
                if i is None or s not in self.prev:
                    continue
                f0, fd0, c0 = self.prev[s]
                f1, fd1 = f_in[k], fd_in[k]
                x = tau[:, 0]
                h00, h10, h01, h11 = 2 * x**3 - 3 * x**2 + 1, x**3 - 2 * x**2 + x, -2 * x**3 + 3 * x**2, x**3 - x**2
                F[:, i] = h00 * f0 + h10 * h * fd0 + h01 * f1 + h11 * h * fd1
                CN[:, i] = c0 + (cn0[k] - c0) * x
            self.bank.run(F, CN, self.rng)
        for k, s in enumerate(sat_ids):
            self.prev[s] = (f_in[k], fd_in[k], cn0[k])
        self.t_prev = t_s
        st = self.bank.state
        idx = np.array([self.slot.get(s, -1) for s in sat_ids], int)
        ok = idx >= 0
        ii = np.where(ok, idx, 0)
        mode = np.where(ok, st[ii, S_MODE], 0).astype(int)
        cn0_est = np.where(ok, st[ii, S_CN0E], np.nan)
        # code/Doppler valid: a tracking mode whose C/N0 estimate confirms the signal (above the drop level)
        valid = (mode >= MODE_FLL) & (np.nan_to_num(cn0_est, nan=-99.0) >= c.loop.cn0_drop_dbhz)
        flags = np.zeros(len(sat_ids), np.uint8)
        flags |= np.where(valid, TRACK_PR_VALID | TRACK_DOPPLER_VALID, 0).astype(np.uint8)
        flags |= np.where(valid & (mode == MODE_PLL), TRACK_CP_VALID, 0).astype(np.uint8)
        if aided:
            flags |= np.uint8(TRACK_AIDED)
        return TrackingEpoch(mode, valid, cn0, cn0_est, np.where(ok, st[ii, S_LOCKT], 0.0),
                             np.where(ok & (mode >= 1), st[ii, S_EPS], 0.0),
                             np.where(ok & (mode >= 1), f_in - st[ii, S_FNCO], 0.0), flags)

    def note_fix(self, t_s, has_fix: bool):
        """The receiver's PVT state: the aiding covariance grows from the last fix."""
        if has_fix or self.t_last_fix is None:
            self.t_last_fix = t_s
