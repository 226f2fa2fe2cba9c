"""Learnable EKF (L-EKF, seed 002 section 2): two recurrent networks embedded
in the EKF recursion, in JAX with flax.linen.

* Input-modification network IMN (section 2.2, Fig. 2), before the
  prediction: Dense1-BN1-Dense2-BN2-LSTM1-LSTM2-Output-Weight,
  kappa_i = Output(.), u~_k = kappa_i * u_k (element-wise).
* Gain-modification network GMN (section 2.3, Fig. 3), before the update:
  the same chain, kappa_g = exp(Output(.)) (21 weights, one per element of
  K), K~_k = kappa_g * K_k.
* Algorithm (section 2.4, Fig. 4): step 1 input modification, step 2
  prediction with u~, step 3 EKF gain, step 4 gain modification, step 5
  update with K~ (Joseph form, ``ekf.update``). Constant Q and R (section 2.4).

Dense layers are tanh(W mu + b) as in the paper; BN is flax's BatchNorm
(batch statistics in training, running averages in use).

Our choices where the paper is silent or does not fit our data (stated in
the README and the training record):

* Network inputs are normalized features, not raw states: the IMN sees
  [h, v, gamma, sin psi, cos psi, chi] of x^_{k-1|k-1}, the radar residual
  (z_k - H x^_{k-1|k-1}) / sigma_R and the nominal u_k; the GMN sees the same
  state features, log sqrt(diag P_{k-1|k-1}) and u~_k / u_k. Raw r in metres
  (6.4e6) would saturate Dense1's tanh, and absolute longitude/latitude would
  tie the networks to the training tracks' geography.
* IMN output: kappa_i = r (tanh(W mu + b) + 1) / 2 with a per-input range r
  (``LekfArch.imn_output_range``); r = 2 is the paper's tanh + 1. Our
  lambda2 spans more than a factor 2 around any nominal value (2 in a glide,
  up to ~75 in a 5 g weave), so r is larger for it.
* Output layers start at zero weight and a bias giving kappa = 1, so the
  untrained L-EKF is exactly the EKF.
* Layer widths: ``LekfArch`` (defaults smaller than the paper's
  256-32-256-256 / 128-16-128-128 so that training fits a 2-core CPU; the
  paper's widths are a configuration, ``LekfArch.paper()``).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import NamedTuple

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np

from hyper_nav_filter.core.target_tracking import ekf
from hyper_nav_filter.core.target_tracking import glide_model as gm

N_IMN_IN = 12
N_GMN_IN = 16


@dataclass(frozen=True)
class LekfArch:
    imn_dense: tuple[int, int] = (64, 16)
    imn_lstm: tuple[int, int] = (64, 64)
    gmn_dense: tuple[int, int] = (32, 8)
    gmn_lstm: tuple[int, int] = (32, 32)
    imn_output_range: tuple[float, float, float] = (6.0, 24.0, 4.0)
    # running-average momentum of BN per filter step: 0.9995 remembers ~2000
    # steps (a few batches); 0.99 remembered only the last chunk's flight phase
    # and the few long tracks still running at a batch's end
    bn_momentum: float = 0.9995

    @classmethod
    def paper(cls) -> "LekfArch":
        """Section 3.1.1 widths: IMN 256-32-256-256, GMN 128-16-128-128."""
        return cls((256, 32), (256, 256), (128, 16), (128, 128))

    def as_dict(self) -> dict:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, d: dict) -> "LekfArch":
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in d.items()})


class ModNet(nn.Module):
    """Dense-BN-Dense-BN-LSTM-LSTM-Output (Figs. 2 and 3); returns the new
    LSTM carries and the output layer's pre-activation."""
    dense: tuple[int, ...]
    lstm: tuple[int, ...]
    n_out: int
    out_bias: tuple[float, ...]
    bn_momentum: float = 0.99

    @nn.compact
    def __call__(self, carry, inp, train: bool, mask=None):
        y = inp
        for i, n in enumerate(self.dense):
            y = jnp.tanh(nn.Dense(n, name=f"dense{i + 1}")(y))
            y = nn.BatchNorm(use_running_average=not train, momentum=self.bn_momentum, name=f"bn{i + 1}")(y, mask=mask)
        new = []
        for i, n in enumerate(self.lstm):
            c, y = nn.OptimizedLSTMCell(n, name=f"lstm{i + 1}")(carry[i], y)
            new.append(c)
        bias = np.asarray(self.out_bias, np.float32)
        out = nn.Dense(self.n_out, kernel_init=nn.initializers.zeros,
                       bias_init=lambda *_: jnp.asarray(bias), name="output")(y)
        return tuple(new), out


class LekfCarry(NamedTuple):
    x: jnp.ndarray          # (B, 7)
    P: jnp.ndarray          # (B, 7, 7)
    imn: tuple              # LSTM carries ((c, h), (c, h)), each (B, width)
    gmn: tuple


def _state_features(x):
    """[h, v, gamma, sin psi, cos psi, tanh chi] normalized, x scaled (B, 7)."""
    psi = x[:, 5] * gm.STATE_SCALE[5]
    return jnp.stack([(x[:, 0] - 40.0) / 10.0, (x[:, 3] - 50.0) / 15.0, x[:, 4] / 10.0,
                      jnp.sin(psi), jnp.cos(psi), jnp.tanh(x[:, 6])], axis=-1)


class Lekf:
    """The L-EKF for a given model, nominal input, Q, R and architecture.
    Pure: variables (params + batch_stats) are passed to every call."""

    def __init__(self, model: gm.GlideModel, u_nominal, Q, R, arch: LekfArch = LekfArch()):
        self.model, self.arch = model, arch
        self.u_nom = jnp.asarray(u_nominal, jnp.float32)
        self.Q, self.R = jnp.asarray(Q, jnp.float32), jnp.asarray(R, jnp.float32)
        self.sigma_r = jnp.sqrt(jnp.diag(self.R))
        r = np.asarray(arch.imn_output_range, float)
        self.imn_range = jnp.asarray(r, jnp.float32)
        self.imn = ModNet(arch.imn_dense, arch.imn_lstm, gm.N_U, tuple(np.arctanh(2.0 / r - 1.0)), arch.bn_momentum)
        self.gmn = ModNet(arch.gmn_dense, arch.gmn_lstm, gm.N_X * gm.N_Z, (0.0,) * (gm.N_X * gm.N_Z),
                          arch.bn_momentum)

    # ---- variables and carries ---------------------------------------------------
    def _zero_lstm(self, widths, batch):
        return tuple((jnp.zeros((batch, n)), jnp.zeros((batch, n))) for n in widths)

    def init_variables(self, key) -> dict:
        k1, k2 = jax.random.split(key)
        b = 2
        vi = self.imn.init(k1, self._zero_lstm(self.arch.imn_lstm, b), jnp.zeros((b, N_IMN_IN)), False)
        vg = self.gmn.init(k2, self._zero_lstm(self.arch.gmn_lstm, b), jnp.zeros((b, N_GMN_IN)), False)
        return {"imn": vi, "gmn": vg}

    def init_carry(self, x0, P0) -> LekfCarry:
        """x0 (B, 7), P0 (B, 7, 7) scaled units."""
        b = x0.shape[0]
        return LekfCarry(jnp.asarray(x0, jnp.float32), jnp.asarray(P0, jnp.float32),
                         self._zero_lstm(self.arch.imn_lstm, b), self._zero_lstm(self.arch.gmn_lstm, b))

    # ---- one radar epoch (batched) -----------------------------------------------
    def step(self, variables, carry: LekfCarry, z, dt, valid, train: bool = False):
        """Section 2.4 steps 1-5 for a batch of tracks; z (B, 3) scaled, dt (B,),
        valid (B,) bool (False: predict only; excluded from BN statistics).
        Returns (carry, outputs, batch_stats) (new running averages when train)."""
        x_prev, P_prev = carry.x, carry.P
        b = x_prev.shape[0]
        # BN statistics over the tracks with a measurement (all of them when none has one)
        mask = (valid | ~jnp.any(valid))[:, None]
        u_nom = jnp.broadcast_to(self.u_nom, (b, gm.N_U))
        # step 1: input modification
        resid = jax.vmap(gm.wrap_innovation)(z - x_prev[:, : gm.N_Z]) / self.sigma_r
        f_imn = jnp.concatenate([_state_features(x_prev), resid, u_nom / jnp.array([1.0, 10.0, 100.0])], -1)
        (imn_c, o_i), upd_i = self.imn.apply(variables["imn"], carry.imn, f_imn, train, mask, mutable=["batch_stats"])
        kappa_i = 0.5 * self.imn_range * (jnp.tanh(o_i) + 1.0)
        u_mod = kappa_i * u_nom
        # step 2: prediction with u~
        pred = jax.vmap(lambda x, P, u, d: ekf.predict(self.model, x, P, u, d, self.Q))
        x_pred, P_pred, _ = pred(x_prev, P_prev, u_mod, dt)
        # step 3: EKF gain
        K, y, S = jax.vmap(lambda xp, Pp, zz: ekf.gain(xp, Pp, zz, self.R))(x_pred, P_pred, z)
        # step 4: gain modification
        log_sig = 0.5 * jnp.log(jnp.maximum(jnp.diagonal(P_prev, axis1=1, axis2=2), 1e-12)) / 3.0
        f_gmn = jnp.concatenate([_state_features(x_prev), log_sig, u_mod / u_nom - 1.0], -1)
        (gmn_c, o_g), upd_g = self.gmn.apply(variables["gmn"], carry.gmn, f_gmn, train, mask, mutable=["batch_stats"])
        K_mod = jnp.exp(o_g).reshape(b, gm.N_X, gm.N_Z) * K
        K_mod = jnp.where(valid[:, None, None], K_mod, 0.0)
        # step 5: update
        x, P = jax.vmap(lambda xp, Pp, k, yy: ekf.update(xp, Pp, k, yy, self.R))(x_pred, P_pred, K_mod, y)
        stats = {"imn": upd_i["batch_stats"], "gmn": upd_g["batch_stats"]}
        return LekfCarry(x, P, imn_c, gmn_c), {"x": x, "P": P, "u": u_mod}, stats

    def run(self, variables, carry: LekfCarry, Z, DT, valid, train: bool = False):
        """Scan over time; Z (T, B, 3), DT (T, B), valid (T, B). In training the
        BN running averages are carried along and returned."""
        def body(c, inp):
            carry_, vars_ = c
            carry_, out, stats = self.step(vars_, carry_, *inp, train=train)
            if train:
                vars_ = {k: {**vars_[k], "batch_stats": stats[k]} for k in vars_}
            return (carry_, vars_), out

        (carry, variables), outs = jax.lax.scan(body, (carry, variables), (Z, DT, valid))
        return carry, outs, variables


def count_parameters(variables) -> int:
    return int(sum(np.size(x) for x in jax.tree_util.tree_leaves(
        {k: v["params"] for k, v in variables.items()})))
