"""Position-residual trigger of a re-estimation (seed 000 section III.A: "if
the calculation error is greater than the threshold, it indicates that there
is a certain deviation in the natural frequency ... the method collects the
IMU and GNSS data closest to the current time").

The statistic is the norm of the mean residual vector (fused position minus
GNSS fix, ENU m) over the last ``averaging_s`` (0: the latest residual alone,
the paper's |r_hat - r_G|); averaging removes white fix noise and keeps a bias.
The trigger fires when the statistic exceeds ``threshold_m`` while armed and at
least ``cooldown_s`` after the last firing; it re-arms only once the statistic
has fallen below ``release_m`` (< threshold: hysteresis), so one excursion
fires once. It does not fire before it has seen ``averaging_s`` of residuals.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TriggerConfig:
    threshold_m: float
    release_m: float
    cooldown_s: float
    averaging_s: float

    def __post_init__(self):
        for name in ("threshold_m", "release_m", "cooldown_s", "averaging_s"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"trigger.{name} must be finite and >= 0, got {v!r}")
        if not self.release_m < self.threshold_m:
            raise ValueError(f"trigger.release_m ({self.release_m}) must be below trigger.threshold_m "
                             f"({self.threshold_m})")


class ResidualTrigger:
    def __init__(self, cfg: TriggerConfig):
        self.cfg = cfg
        self._res: deque = deque()             # (t, residual ENU)
        self._sum = np.zeros(3)
        self.armed = True
        self.last_fire_t_s = -np.inf
        self.statistic_m = 0.0
        self.n_fired = 0
        self.n_suppressed_cooldown = 0
        self._t_first = None

    def update(self, t_s: float, residual_enu_m) -> bool:
        """Add the residual of epoch t_s (in time order); True when the trigger fires."""
        r = np.asarray(residual_enu_m, float)
        if r.shape != (3,) or not np.all(np.isfinite(r)) or not np.isfinite(t_s):
            raise ValueError(f"residual must be 3 finite numbers at a finite epoch, got {residual_enu_m!r} at {t_s!r}")
        if self._t_first is None:
            self._t_first = t_s
        self._res.append((t_s, r))
        self._sum += r
        while self._res and self._res[0][0] < t_s - self.cfg.averaging_s - 1e-9:
            self._sum -= self._res.popleft()[1]
        self.statistic_m = float(np.linalg.norm(self._sum / len(self._res)))
        if not self.armed:
            if self.statistic_m < self.cfg.release_m:
                self.armed = True
            return False
        if self.statistic_m <= self.cfg.threshold_m or t_s - self._t_first < self.cfg.averaging_s - 1e-9:
            return False
        if t_s - self.last_fire_t_s < self.cfg.cooldown_s:
            self.n_suppressed_cooldown += 1
            return False
        self.armed = False
        self.last_fire_t_s = t_s
        self.n_fired += 1
        return True
