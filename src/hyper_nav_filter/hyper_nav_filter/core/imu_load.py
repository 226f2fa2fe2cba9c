"""Pairing of IMU samples with the structure's load samples (seed 000, the
elastic lever arm's known input u_q of eq. 22): two streams, the IMU's
(t, mean rate, mean specific force) over (previous stamp, t] and the load
sensor's (t, mean specific force) over its own shorter intervals, arriving
in any relative order. An IMU sample is released once a load sample stamped
at or after its end has arrived, with the load samples stamped inside its
interval, (n, 3); with none inside, without load (``None``). When more than
``max_held`` IMU samples wait (a load stream that stopped), the oldest go
without. Used by the fusion node's IMU source and by the lever-arm node, so
both take the same samples live as the offline core takes from the simulator.
"""
from __future__ import annotations

from collections import deque

import numpy as np

EPS_S = 1e-6


class ImuLoadPairing:
    def __init__(self, max_held: int = 1000):
        self.max_held = int(max_held)
        self._held: deque = deque()       # (t_s, omega_b_radps, f_b_mps2)
        self._loads: deque = deque()      # (t_s, load_f_b_mps2)
        self.n_without_load = 0

    @property
    def n_held(self) -> int:
        return len(self._held)

    def add_load(self, t_s: float, load_f_b_mps2) -> bool:
        """A load sample (mean specific force over its interval ending at t_s);
        False (ignored) when not after the previous one."""
        if self._loads and t_s <= self._loads[-1][0]:
            return False
        self._loads.append((float(t_s), np.asarray(load_f_b_mps2, float)))
        return True

    def add_imu(self, t_s: float, omega_b_radps, f_b_mps2) -> None:
        self._held.append((float(t_s), omega_b_radps, f_b_mps2))

    def ready(self, t_prev_s):
        """Yield (t_s, omega, f, load (n, 3) or None) of the IMU samples now
        complete, in order; ``t_prev_s()`` gives the end of the previous
        interval as the consumer has it (load samples at or before it belong
        to earlier intervals and are dropped)."""
        while self._held:
            t_load = self._loads[-1][0] if self._loads else -np.inf
            if t_load < self._held[0][0] - EPS_S and len(self._held) <= self.max_held:
                return
            t, w, f = self._held.popleft()
            t_prev = t_prev_s()
            while self._loads and self._loads[0][0] <= t_prev + EPS_S:
                self._loads.popleft()
            inside = []
            while self._loads and self._loads[0][0] <= t + EPS_S:
                inside.append(self._loads.popleft()[1])
            if not inside:
                self.n_without_load += 1
            yield t, w, f, (np.array(inside) if inside else None)
