"""Carrier-tracking lock model for a high-dynamics receiver (seed 004 section 2.1).

Seed 004 section 2.1 (Fig. 1): along a boost-glide trajectory (Ma >= 7 in the
glide, section 3), the L1/L5 Doppler shift exceeds 5 kHz everywhere except in
the final low-speed dive, "far above the tracking-loop bandwidth of common
receivers", and a large Doppler "raises the frequency search bandwidth needed
for acquisition, so acquisition may fail"; lock is lost from t = 30 s in their
simulation (Table 3). We turn that argument into two criteria:

1. Frequency window (acquisition / FLL pull-in). A receiver predicts each
   satellite's Doppler from almanac + its last fix and searches (and holds its
   FLL-assisted loop) within +-``doppler_limit_hz`` (default 5 kHz, the paper's
   figure) of that prediction. What it cannot predict is the vehicle-induced
   part -u.v_rx/lambda (for a conventional receiver without inertial aiding);
   the satellite's own +-4 kHz is predicted. Criterion: |f_D,vehicle| > limit.
   With ``doppler_reference='total'`` the full line-of-sight Doppler (satellite +
   vehicle, the quantity of the paper's Fig. 1) is compared instead.
2. Dynamic stress. For a 2nd-order PLL (noise bandwidth B_n, natural frequency
   w0 = B_n / 0.53) the steady-state phase error under a Doppler rate fdot
   [Hz/s] is theta_e = 360 fdot / w0^2 [deg] (Kaplan & Hegarty, 5.6.1); lock is
   lost when theta_e > ``phase_error_limit_deg`` (default 30 deg, inside the 45
   deg 3-sigma PLL rule with margin for jitter). Defaults B_n = 15 Hz ->
   fdot_max = 30/360 * (15/0.53)^2 = 66.8 Hz/s (12.7 m/s^2 line-of-sight at L1).

A satellite that lost lock is re-acquired once both criteria have been met
continuously for ``reacquisition_s``. Scripted outage windows [(t0, t1), ...]
(all satellites, or per satellite) force loss of lock inside [t0, t1) and
re-acquisition time counts from t1.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from hyper_nav_gnss.constants import C_MPS


@dataclass
class LockConfig:
    doppler_limit_hz: float = 5000.0
    doppler_reference: str = "vehicle"      # 'vehicle' or 'total'
    loop_bandwidth_hz: float = 15.0
    phase_error_limit_deg: float = 30.0
    reacquisition_s: float = 2.0
    outages: list = field(default_factory=list)         # [(t0, t1), ...] all satellites
    sat_outages: dict = field(default_factory=dict)     # {'G05': [(t0, t1), ...]}

    @property
    def doppler_rate_limit_hzps(self) -> float:
        """Max Doppler rate of a 2nd-order PLL: theta_max/360 * (B_n/0.53)^2 [Hz/s]."""
        w0 = self.loop_bandwidth_hz / 0.53
        return self.phase_error_limit_deg / 360.0 * w0 ** 2


def vehicle_doppler_hz(u_los_e, v_rx_e_mps, carrier_hz):
    """Vehicle-induced Doppler -(-u.v)/lambda = u.v_rx/lambda [Hz] (u: unit
    receiver->satellite vectors (N,3); approaching the satellite = positive)."""
    return np.einsum("ki,i->k", np.atleast_2d(u_los_e), np.asarray(v_rx_e_mps, float)) * np.asarray(carrier_hz) / C_MPS


class LockModel:
    """Stateful per-satellite lock tracker. Call :meth:`update` at increasing times."""

    def __init__(self, config: LockConfig | None = None):
        self.cfg = config or LockConfig()
        self._locked: dict[str, bool] = {}
        self._ok_since: dict[str, float] = {}
        self._last: dict[str, tuple[float, float]] = {}

    def _scripted(self, sat, t):
        wins = list(self.cfg.outages) + list(self.cfg.sat_outages.get(sat, []))
        return any(t0 <= t < t1 for t0, t1 in wins)

    def conditions_ok(self, doppler_hz, doppler_rate_hzps):
        """Boolean per satellite: both criteria satisfied (ignores history)."""
        return (np.abs(doppler_hz) <= self.cfg.doppler_limit_hz) & \
            (np.abs(doppler_rate_hzps) <= self.cfg.doppler_rate_limit_hzps)

    def update(self, t_s, sat_ids, doppler_hz, doppler_rate_hzps=None):
        """Lock state after epoch t_s. doppler_hz: the Doppler the criterion uses
        (vehicle part or total, per config); doppler_rate_hzps: if None, the
        backward difference from the previous call for that satellite (0 at first).
        Returns boolean array (True = tracking)."""
        dop = np.asarray(doppler_hz, float)
        if doppler_rate_hzps is None:
            rate = np.array([(d - self._last[s][1]) / (t_s - self._last[s][0])
                             if s in self._last and t_s > self._last[s][0] else 0.0
                             for s, d in zip(sat_ids, dop)])
        else:
            rate = np.asarray(doppler_rate_hzps, float)
        ok = self.conditions_ok(dop, rate)
        out = np.zeros(len(sat_ids), bool)
        for k, s in enumerate(sat_ids):
            self._last[s] = (t_s, dop[k])
            good = bool(ok[k]) and not self._scripted(s, t_s)
            if not good:
                self._locked[s] = False
                self._ok_since.pop(s, None)
                continue
            if s not in self._locked:          # first sight: assume acquired
                self._locked[s] = True
            if not self._locked[s]:
                t0 = self._ok_since.setdefault(s, t_s)
                if t_s - t0 >= self.cfg.reacquisition_s:
                    self._locked[s] = True
            out[k] = self._locked[s]
        return out
