"""A receiver that does not notice its loss of lock (seed 004 Table 4 case
"without online compensation": "wrong observations are injected into the
filter", section 3).

After a channel loses lock the receiver keeps reporting it as locked, its
code and carrier NCOs coasting on the last tracked Doppler (a receiver
without a lock detector on that channel): the pseudorange grows with the
last range rate and the rate stays frozen,

    rho(t) = rho(t_loss) + rho_dot(t_loss) (t - t_loss) + n,   rho_dot(t) = rho_dot(t_loss) + n',

with n ~ N(0, ``pseudorange_noise_m``^2), n' ~ N(0, ``rate_noise_mps``^2)
(the discriminators output noise only; 3 m and 0.5 m/s are our choice, the
paper gives no model). The error is the unmodelled line-of-sight
acceleration, integrated twice: metres within seconds in the boost-glide's
manoeuvres. The reported sigmas stay the ones of a tracking channel.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from hyper_nav_gnss.observations import RawGnssEpoch


class UndetectedLockLoss:
    """Turns the receiver's epochs into those of a receiver without lock
    detection. Call :meth:`epoch` in time order."""

    def __init__(self, rng: np.random.Generator, pseudorange_noise_m: float = 3.0, rate_noise_mps: float = 0.5):
        self.rng = rng
        self.pr_noise = float(pseudorange_noise_m)
        self.rate_noise = float(rate_noise_mps)
        self._last: dict[tuple[str, int], tuple[float, float, float]] = {}   # (t_rx, rho, rho_dot) while locked

    def epoch(self, raw: RawGnssEpoch) -> RawGnssEpoch:
        pr = np.array(raw.pseudorange_m, float)
        rate = np.array(raw.rate_mps, float)
        locked = np.array(raw.locked, bool)
        for k, (s, p) in enumerate(zip(raw.system, raw.prn)):
            key = (s, int(p))
            if locked[k]:
                self._last[key] = (raw.t_rx_gpst_s, pr[k], rate[k])
            elif key in self._last:
                t0, pr0, rate0 = self._last[key]
                pr[k] = pr0 + rate0 * (raw.t_rx_gpst_s - t0) + self.pr_noise * self.rng.standard_normal()
                rate[k] = rate0 + self.rate_noise * self.rng.standard_normal()
                locked[k] = True
        return replace(raw, pseudorange_m=pr, rate_mps=rate, locked=locked)
