"""Virtual GNSS under receiver lock loss (seed 004 section 2.3, Fig. 2b):
the state machine behind the ``virtual_gnss`` node, pure Python.

Inputs (what the node subscribes to), in arrival order:

* broadcast records (``gnss/ephemeris``): validated and stored while they
  arrive (:class:`~hyper_nav_gnss.observations.EphemerisStore`,
  newest per toe); a malformed record or one already expired at the latest
  receiver epoch (|t - toe| > 2 h GPS, 1 h BDS) is rejected with the reason
  and counted;
* receiver epochs (``gnss/raw``): the tracking state per satellite;
* the position source: receiver fixes (``gnss/fix`` + ``gnss/vel``) for the
  alpha-beta extrapolation (:mod:`.alpha_beta`), or the fused solution
  (``nav/state``) + IMU (:mod:`.fused_extrapolation`).

Receiver clock: the node keeps its own estimate (``nav/state`` carries no
clock): at every epoch with locked satellites, the common offset of their
corrected pseudoranges from the ranges to the source's position (median),
smoothed by an alpha-beta tracker of bias and drift
(``clock_drift_rate_sigma_mps2``, ``clock_sigma_m``), extrapolated with the
drift through the outage.

Receiver epochs are queued (:meth:`VirtualGnss.add_raw`) and processed in
epoch order by :meth:`VirtualGnss.ready`, once the IMU is ``input_hold_s``
past the epoch (with an IMU stream; without one, at once) and, with the
fused source, a fused state later than the one it uses has arrived. What an
epoch uses is chosen by stamps: the newest fused state stamped at least
``fused_state_delay_s`` before it, the fixes stamped before it, the
broadcast records received (stamped) by it; so, for inputs up to
``input_hold_s`` late, the result does not depend on the arrival order of
the topics (live node = offline run, issue 22).

Per receiver epoch: a satellite is *lost* when
it was locked at an earlier epoch and is not locked now; for the lost
satellites whose stored record is valid at the epoch and that are above the
mask seen from the extrapolated position, the virtual pseudoranges and
rates of the epoch are built (:func:`.virtual_pseudoranges.virtual_epoch`,
eqs. 8-11) and returned, time-stamped with the epoch itself. Nothing is
produced while every satellite that was ever locked is locked, nothing for
a satellite in the epoch where its lock returns (the real measurement is
used from then on), nothing for an epoch older than one already processed,
and nothing when the source cannot give a position at the epoch (no fix or
state yet, a state too old, an alpha-beta extrapolation beyond
``max_extrapolation_s``): all counted, so nothing stale is ever published
across the lock-loss begin and end.
"""
from __future__ import annotations

from collections import Counter

import numpy as np

from hyper_nav_gnss.orbits.ephemeris import C_MPS, system_time_s
from hyper_nav_gnss.observations import EphemerisStore, MalformedGnssInput, RawGnssEpoch, check_raw_epoch
from hyper_nav_filter.core.raw_to_pseudoranges import ReceiverCorrections, corrected_pseudoranges
from hyper_nav_filter.core.nav_state import ImuSample, NavState
from hyper_nav_filter.core.tightly_coupled import sagnac_rotate

from hyper_nav_aiding.virtual_gnss.core.alpha_beta import AlphaBetaTracker
from hyper_nav_aiding.virtual_gnss.core.fused_extrapolation import FusedStateExtrapolator, StaleInput
from hyper_nav_aiding.virtual_gnss.core.virtual_gnss_config import VirtualGnssConfig
from hyper_nav_aiding.virtual_gnss.core.virtual_pseudoranges import paper_noise_sigma_m, sky, virtual_epoch

EPHEMERIS_VALIDITY_S = {"G": 7200.0, "C": 3600.0}     # |t - toe| limits (select_ephemeris)


class VirtualGnss:
    def __init__(self, cfg: VirtualGnssConfig, corrections: ReceiverCorrections, lever_arm_b_m=(0.0, 0.0, 0.0),
                 receiver_rate_hz: float = 1.0, rng: np.random.Generator | None = None):
        self.cfg = cfg
        self.corrections = corrections
        self.rng = rng if cfg.add_noise else None
        self.store = EphemerisStore()
        self.counters: Counter = Counter()
        self.last_error = ""
        self._ever_locked: set[tuple[str, int]] = set()
        self._t_last: float | None = None
        self._t_rx_last: float | None = None
        self.tracker = AlphaBetaTracker(cfg.alpha_beta_accel_sigma_mps2, cfg.alpha_beta_fix_sigma_m,
                                        1.0 / receiver_rate_hz)
        self.clock = AlphaBetaTracker(cfg.clock_drift_rate_sigma_mps2, cfg.clock_sigma_m, 1.0 / receiver_rate_hz)
        self.fused = FusedStateExtrapolator(lever_arm_b_m, cfg.max_state_age_s, cfg.fused_state_delay_s)
        self._queue: list[RawGnssEpoch] = []
        self._fixes: list[tuple] = []
        self.geometry: dict[float, tuple] = {}        # t_s -> (elevation, azimuth) of the output's channels

    # ----------------------------------------------------------------------------------------- inputs
    def reject(self, counter: str, msg: str) -> str:
        self.counters[counter] += 1
        self.last_error = msg
        return msg

    def add_ephemeris(self, eph, received_s: float = -np.inf) -> str | None:
        """Store a broadcast record received at ``received_s`` (its message's
        stamp); the reason if rejected (malformed or expired)."""
        try:
            if self._t_rx_last is not None:
                age = abs(float(system_time_s(eph.system, self._t_rx_last)) - eph.toe_s)
                limit = EPHEMERIS_VALIDITY_S.get(eph.system, 7200.0)
                if np.isfinite(age) and age > limit:
                    return self.reject("rejected_ephemeris_expired",
                                        f"gnss ephemeris {eph.sat_id}: toe is {age:.0f} s from the latest receiver "
                                        f"epoch (valid +-{limit:.0f} s): expired")
            self.store.add(eph, received_s)
        except (MalformedGnssInput, ValueError, TypeError, AttributeError) as exc:
            return self.reject("rejected_ephemeris_malformed", str(exc))
        self.counters["ephemerides_stored"] += 1
        return None

    def add_fix(self, t_s: float, r_e_m, v_e_mps=None) -> None:
        """A receiver fix (alpha-beta source), ECEF antenna position (and
        velocity, used only to start the tracker). Fixes enter the tracker
        when a later receiver epoch is processed (a fix is not used for its
        own epoch, whichever of the two arrives first)."""
        if not (np.all(np.isfinite(r_e_m)) and (v_e_mps is None or np.all(np.isfinite(v_e_mps)))):
            self.reject("rejected_fix_malformed", f"gnss fix at {t_s:.3f} s: non-finite position/velocity")
            return
        self._fixes.append((float(t_s), np.asarray(r_e_m, float), None if v_e_mps is None else
                            np.asarray(v_e_mps, float)))

    def add_state(self, state: NavState, pos_sigma_m: float = 0.0) -> None:
        """A fused solution (fused source) with its per-axis position 1-sigma [m]."""
        self.fused.add_state(state, pos_sigma_m)

    def add_imu(self, sample: ImuSample) -> None:
        self.fused.add_imu(sample)

    # ----------------------------------------------------------------------------------------- output
    def _position(self, t_s: float):
        """(r_e, v_e, pos sigma) of the source at t_s."""
        if self.cfg.position_source == "fused":
            return self.fused.at(t_s)
        tr = self.tracker
        if tr.t_s is None:
            raise StaleInput("no receiver fix yet for the alpha-beta extrapolation")
        if t_s - tr.t_s > self.cfg.max_extrapolation_s:
            raise StaleInput(f"last receiver fix {t_s - tr.t_s:.1f} s ago (limit {self.cfg.max_extrapolation_s} s)")
        r, v = tr.predict(t_s)
        return r, v, tr.position_sigma_m(t_s)

    def _clock_at(self, t_s: float):
        """(bias m, drift m/s, sigma m) of the receiver clock extrapolated to t_s."""
        if self.clock.t_s is None:
            raise StaleInput("no receiver clock estimate yet (no locked epoch with a position)")
        b, d = self.clock.predict(t_s)
        return float(b[0]), float(d[0]), self.clock.position_sigma_m(t_s)

    def _track_clock(self, raw: RawGnssEpoch) -> None:
        """Clock measurement of a real epoch: median over its locked channels of
        corrected pseudorange - range to the source's position."""
        idx = [k for k, ok in enumerate(raw.locked) if ok and raw.system[k] in ("G", "C")]
        ephs = [self.store.select(raw.system[k], int(raw.prn[k]), raw.t_rx_gpst_s, raw.t_s) for k in idx]
        sel = [(k, e) for k, e in zip(idx, ephs) if e is not None]
        if not sel:
            return
        try:
            r_e, _, _ = self._position(raw.t_s)
        except StaleInput:
            return
        b_prev = self.clock.predict(raw.t_s)[0][0] if self.clock.t_s is not None else 0.0
        p = corrected_pseudoranges(raw, [k for k, _ in sel], tuple(e for _, e in sel), r_e, self.corrections,
                                   b_prev)
        rr = sagnac_rotate(p.sat_pos_e_m, np.linalg.norm(p.sat_pos_e_m - r_e, axis=1) / C_MPS)
        b = float(np.median(p.pseudorange_m - np.linalg.norm(rr - r_e, axis=1)))
        self.clock.update(raw.t_s, [b, 0.0, 0.0])

    def lost_satellites(self, raw: RawGnssEpoch) -> list[tuple[str, int]]:
        """Satellites locked at an earlier epoch and not locked in ``raw``."""
        locked_now = {(s, int(p)) for s, p, ok in zip(raw.system, raw.prn, raw.locked) if ok}
        return sorted(self._ever_locked - locked_now)

    def add_raw(self, raw: RawGnssEpoch) -> str | None:
        """Queue a receiver epoch; the reason if rejected (malformed, or not
        newer than the last one queued)."""
        try:
            check_raw_epoch(raw)
        except MalformedGnssInput as exc:
            return self.reject("rejected_raw_malformed", str(exc))
        if self._t_last is not None and raw.t_s <= self._t_last:
            return self.reject("rejected_raw_out_of_order", f"gnss raw at {raw.t_s:.3f} s after {self._t_last:.3f} s")
        self._t_last, self._t_rx_last = float(raw.t_s), float(raw.t_rx_gpst_s)
        self._queue.append(raw)
        return None

    @property
    def pending_t_s(self) -> float | None:
        """Stamp of the oldest receiver epoch waiting to be processed (None: none)."""
        return self._queue[0].t_s if self._queue else None

    def ready(self) -> list[RawGnssEpoch]:
        """Virtual epochs of the queued receiver epochs that can be processed
        now (all with the alpha-beta source; with the fused source those the
        IMU has reached), in epoch order."""
        out = []
        while self._queue:
            raw = self._queue[0]
            t_imu = self.fused.imu_t_s
            if t_imu is not None and t_imu < raw.t_s + self.cfg.input_hold_s - 1e-9:
                break                                 # inputs stamped by the epoch may still come
            if self.cfg.position_source == "fused":
                # the IMU must reach the epoch, and a state newer than the one to use must have
                # arrived (states come in order: the one used is then final), unless the IMU is
                # max_state_age_s past the epoch (then no newer state is coming)
                t_imu, t_state = self.fused.imu_t_s, self.fused.state_t_s
                if t_imu is None or t_imu < raw.t_s - 1e-9:
                    break
                if (t_state is None or t_state < raw.t_s - self.cfg.fused_state_delay_s - 1e-9) and \
                        t_imu < raw.t_s + self.cfg.max_state_age_s:
                    break
            self._queue.pop(0)
            v = self._process(raw)
            if v is not None:
                out.append(v)
        return out

    def on_raw(self, raw: RawGnssEpoch) -> list[RawGnssEpoch]:
        """:meth:`add_raw` then :meth:`ready`."""
        self.add_raw(raw)
        return self.ready()

    def _process(self, raw: RawGnssEpoch) -> RawGnssEpoch | None:
        """The virtual epoch for one receiver epoch, or None (module docstring)."""
        self._fixes.sort(key=lambda f: f[0])
        while self._fixes and self._fixes[0][0] < raw.t_s - 1e-9:
            self.tracker.update(*self._fixes.pop(0))
        lost = self.lost_satellites(raw)
        self._ever_locked |= {(s, int(p)) for s, p, ok in zip(raw.system, raw.prn, raw.locked) if ok}
        self._track_clock(raw)
        if not lost:
            self.counters["epochs_all_locked"] += 1
            return None
        try:
            r_e, v_e, s_pos = self._position(raw.t_s)
            b, d, s_clk = self._clock_at(raw.t_s)
        except StaleInput as exc:
            self.reject("virtual_epochs_no_position", str(exc))
            return None
        ephs = []
        for s, p in lost:
            eph = self.store.select(s, p, raw.t_rx_gpst_s, raw.t_s)
            if eph is None:
                self.reject("virtual_channels_no_valid_ephemeris",
                             f"{s}{p:02d}: no stored ephemeris valid at the epoch (expired or never received)")
            else:
                ephs.append(eph)
        if not ephs:
            self.counters["virtual_epochs_empty"] += 1
            return None
        _, _, _, _, el, az, _ = sky(ephs, raw.t_rx_gpst_s - b / C_MPS, r_e)
        keep = el >= np.deg2rad(self.cfg.elevation_mask_deg)
        self.counters["virtual_channels_below_mask"] += int((~keep).sum())
        ephs = [e for e, k in zip(ephs, keep) if k]
        if not ephs:
            self.counters["virtual_epochs_empty"] += 1
            return None
        el = el[keep]
        self.geometry[float(raw.t_s)] = (el, az[keep])
        while len(self.geometry) > 100:
            self.geometry.pop(next(iter(self.geometry)))
        base = paper_noise_sigma_m(el) if self.cfg.pseudorange_sigma_m == "elevation" else \
            np.full(len(ephs), float(self.cfg.pseudorange_sigma_m))
        sig = np.sqrt(base ** 2 + s_pos ** 2 + s_clk ** 2) if self.cfg.consistent_covariance else base
        out = virtual_epoch(raw.t_s, raw.t_rx_gpst_s, ephs, r_e, v_e, b, d, self.corrections, sig,
                            self.cfg.pseudorange_rate_sigma_mps, self.rng)
        self.counters["virtual_epochs"] += 1
        self.counters["virtual_channels"] += len(ephs)
        return out
