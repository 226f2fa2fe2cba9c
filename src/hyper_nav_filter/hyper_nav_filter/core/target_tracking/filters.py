"""The four trackers behind one interface, selected by name
(``TrackerConfig.filter_type``): a registry, no type dispatch.

``build_filter(cfg, lekf=None)`` returns a ``TrackFilter`` whose ``init``
and ``step`` work on a batch of independent tracks (B): ``init(x0 (B, 7),
P0 (B, 7, 7))`` and ``step(carry, z (B, 3), dt (B,), valid (B,)) ->
(carry, {"x", "P", "u"})``, all in the scaled units of ``glide_model``.
``run_batch`` scans a step over a measurement sequence.
"""
from __future__ import annotations

from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp

from hyper_nav_filter.core.target_tracking import aekf, ekf, imm
from hyper_nav_filter.core.target_tracking.config import FILTER_TYPES, TrackerConfig
from hyper_nav_filter.core.target_tracking.lekf import Lekf, LekfArch


class TrackFilter(NamedTuple):
    name: str
    init: Callable
    step: Callable


def _batched(step_one):
    return jax.vmap(step_one, in_axes=(0, 0, 0, 0))


def _ekf(cfg: TrackerConfig, _lekf):
    u, Q, R = (jnp.asarray(a, jnp.float32) for a in (cfg.u_nominal, cfg.Q, cfg.R))
    step = _batched(lambda c, z, dt, v: ekf.ekf_step(cfg.model, u, Q, R, c, z, dt, v))
    return TrackFilter("EKF", lambda x0, P0: ekf.EkfCarry(jnp.asarray(x0, jnp.float32), jnp.asarray(P0, jnp.float32)),
                       step)


def _aekf(cfg: TrackerConfig, _lekf):
    u, Q, R = (jnp.asarray(a, jnp.float32) for a in (cfg.u_nominal, cfg.Q, cfg.R))
    step = _batched(lambda c, z, dt, v: aekf.aekf_step(cfg.model, u, Q, R, cfg.aekf_forgetting, c, z, dt, v))
    return TrackFilter("AEKF", jax.vmap(lambda x0, P0: aekf.init(jnp.asarray(x0, jnp.float32),
                                                                 jnp.asarray(P0, jnp.float32))), step)


def _imm(cfg: TrackerConfig, _lekf):
    U = jnp.asarray(imm.mode_inputs(cfg.u_nominal, cfg.imm_lateral_c_l), jnp.float32)
    Qs = jnp.asarray([s * cfg.Q for s in cfg.imm_q_scale], jnp.float32)
    R = jnp.asarray(cfg.R, jnp.float32)
    Tm = jnp.asarray(imm.transition_matrix(len(cfg.imm_lateral_c_l), cfg.imm_p_stay), jnp.float32)
    step = _batched(lambda c, z, dt, v: imm.imm_step(cfg.model, U, Qs, R, Tm, c, z, dt, v))
    n = len(cfg.imm_lateral_c_l)
    return TrackFilter("IMM", jax.vmap(lambda x0, P0: imm.init(jnp.asarray(x0, jnp.float32),
                                                               jnp.asarray(P0, jnp.float32), n)), step)


def _lekf(cfg: TrackerConfig, lekf):
    if lekf is None:
        raise ValueError("tracker.filter_type LEKF: trained parameters are needed (tracker.lekf_parameters)")
    arch, variables = lekf
    net = Lekf(cfg.model, cfg.u_nominal, cfg.Q, cfg.R, arch)

    def step(carry, z, dt, valid):
        carry, out, _ = net.step(variables, carry, z, dt, valid, train=False)
        return carry, out

    return TrackFilter("LEKF", net.init_carry, step)


_BUILDERS = dict(zip(FILTER_TYPES, (_ekf, _aekf, _lekf, _imm)))      # the names: config.FILTER_TYPES


def build_filter(cfg: TrackerConfig, lekf: tuple[LekfArch, dict] | None = None,
                 filter_type: str | None = None) -> TrackFilter:
    """The tracker named ``filter_type`` (default ``cfg.filter_type``);
    ``lekf`` = (architecture, variables) of a trained L-EKF."""
    return _BUILDERS[filter_type or cfg.filter_type](cfg, lekf)


def run_batch(filt: TrackFilter, x0, P0, Z, DT, valid=None):
    """Run over time-major sequences Z (T, B, 3), DT (T, B); returns the
    final carry and the stacked outputs {"x": (T, B, 7), "P": (T, B, 7, 7), "u": (T, B, 3)}."""
    if valid is None:
        valid = jnp.ones(Z.shape[:2], dtype=bool)

    def body(c, inp):
        c, out = filt.step(c, *inp)
        return c, {k: out[k] for k in ("x", "P", "u")}

    return jax.lax.scan(body, filt.init(x0, P0), (jnp.asarray(Z, jnp.float32), jnp.asarray(DT, jnp.float32),
                                                  jnp.asarray(valid)))
