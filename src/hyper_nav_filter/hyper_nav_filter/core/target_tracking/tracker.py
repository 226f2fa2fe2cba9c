"""Online tracker: one target, one radar measurement at a time, any of the
four filters (``filters.build_filter``). The tracker node wraps it; the
offline commands run the same filter step over whole tracks
(``filters.run_batch``), and a test checks that both give the same estimates.

Bad input is rejected and counted, never raised: a non-finite measurement
(``rejected_radar_nan``), a stamp not after the last accepted one
(``rejected_radar_out_of_order``; the initial estimate's own epoch is
accepted once). A gap longer than 1.5 radar intervals is bridged by
predict-only steps of one nominal interval each (the L-EKF was trained at
that interval).
"""
from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from hyper_nav_filter.core.target_tracking import glide_model as gm
from hyper_nav_filter.core.target_tracking.config import TrackerConfig
from hyper_nav_filter.core.target_tracking.filters import build_filter

COUNTERS = ("accepted", "predict_only_steps", "rejected_radar_nan", "rejected_radar_out_of_order")


@dataclass(frozen=True)
class Estimate:
    t_s: float
    x: np.ndarray          # (7,) physical: h m, theta rad, phi rad, v m/s, gamma rad, psi rad, chi
    P: np.ndarray          # (7, 7) physical units
    u: np.ndarray          # (3,) input used (u~ for the L-EKF)


class Tracker:
    def __init__(self, cfg: TrackerConfig, x0_phys, t0_s: float, dt_nominal_s: float = 1.0, lekf=None):
        self.cfg = cfg
        self.dt_nominal_s = float(dt_nominal_s)
        self.filter = build_filter(cfg, lekf)
        x0 = jnp.asarray(gm.to_scaled(x0_phys)[None], jnp.float32)
        self.carry = self.filter.init(x0, jnp.asarray(cfg.P0[None], jnp.float32))
        self._step = jax.jit(self.filter.step)
        self.t_s = float(t0_s)
        self._first = True
        self.counters = {k: 0 for k in COUNTERS}
        self.last: Estimate = Estimate(self.t_s, np.asarray(x0_phys, float), gm.covariance_to_physical(cfg.P0),
                                       np.asarray(cfg.u_nominal, float))

    def warm_up(self) -> None:
        """Compile the step (the first call takes seconds) without changing the track."""
        jax.block_until_ready(self._step(self.carry, jnp.zeros((1, gm.N_Z)), jnp.ones((1,)), jnp.zeros((1,), bool)))

    def add_measurement(self, t_s: float, z_phys) -> str | None:
        """Filter one radar measurement z = [alt_m, lon_rad, lat_rad] at t_s;
        returns None when accepted, else the counter name of the rejection."""
        z_phys = np.asarray(z_phys, float)
        if z_phys.shape != (gm.N_Z,) or not (np.all(np.isfinite(z_phys)) and np.isfinite(t_s)):
            return self._reject("rejected_radar_nan")
        if t_s < self.t_s or (t_s == self.t_s and not self._first):
            return self._reject("rejected_radar_out_of_order")
        while t_s - self.t_s > 1.5 * self.dt_nominal_s:
            self._advance(self.t_s + self.dt_nominal_s, None)
            self.counters["predict_only_steps"] += 1
        self._advance(t_s, z_phys)
        self._first = False
        self.counters["accepted"] += 1
        return None

    def _advance(self, t_s: float, z_phys) -> None:
        valid = z_phys is not None
        z = gm.measurement_to_scaled(z_phys) if valid else np.zeros(gm.N_Z)
        self.carry, out = self._step(self.carry, jnp.asarray(z[None], jnp.float32),
                                     jnp.asarray([t_s - self.t_s], jnp.float32), jnp.asarray([valid]))
        self.t_s = float(t_s)
        self.last = Estimate(self.t_s, gm.to_physical(np.asarray(out["x"][0])),
                             gm.covariance_to_physical(np.asarray(out["P"][0])), np.asarray(out["u"][0], float))

    def _reject(self, reason: str) -> str:
        self.counters[reason] += 1
        return reason
