"""End-to-end training of the L-EKF through the filter recursion (seed 002
section 3.1): weighted mean absolute error (section 3.1.3) and RMSprop
(section 3.1.4) with optax.

Sequences: every training track is filtered from its first radar epoch to
its last, in chunks of ``chunk`` steps (the paper's segments of length 100);
gradients flow through the whole recursion inside a chunk (filter state,
covariance, both LSTMs) and are cut between chunks, while the filter and LSTM
states carry over (truncated back-propagation through time). A batch holds
``batch`` tracks side by side; tracks that end early are masked out of the
loss and the BatchNorm statistics.

Loss (section 3.1.3)::

    L = 1/N sum_i ( c w_x |x^_i|i - x_i| + (1 - c) w_u |u~_i - u_i| )

with w_x = [50, 1000, 1000, 0.5, 10000, 5000] and w_u = [1, 1, 0.01],
c = 0.5, read with h in km, angles in rad, v in m/s, T_chi in s (the paper
does not give the units; these make the six terms of a good track of similar
size). Heading errors are wrapped.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import jax
import jax.numpy as jnp
import numpy as np
import optax

from . import glide_model as gm
from .lekf import Lekf, LekfCarry

W_X = np.array([50.0, 1000.0, 1000.0, 0.5, 10000.0, 5000.0])      # h km, theta, phi rad, v m/s, gamma, psi rad
W_U = np.array([1.0, 1.0, 0.01])
LOSS_C = 0.5
# w_x per scaled unit (scaled units: km, mrad, mrad, 100 m/s, mrad, 10 mrad)
_W_X_SCALED = W_X * np.array([1.0, 1e-3, 1e-3, 100.0, 1e-3, 1e-2])


@dataclass(frozen=True)
class TrainConfig:
    epochs: int = 20
    batch: int = 32
    chunk: int = 100
    learning_rate: float = 1e-3
    clip_global_norm: float = 1.0       # not in the paper: keeps early recursions from exploding
    seed: int = 0

    def as_dict(self) -> dict:
        return asdict(self)


def wmae(x_est, x_true, u_est, u_true, mask):
    """Section 3.1.3 loss over (T, B) steps; x in scaled units (7), u physical.
    ``mask`` (T, B) selects the steps that count."""
    e = jnp.abs(x_est[..., :6] - x_true[..., :6])
    half = np.pi / gm.STATE_SCALE[5]
    e = e.at[..., 5].set(jnp.abs(jnp.mod(x_est[..., 5] - x_true[..., 5] + half, 2 * half) - half))
    lx = jnp.sum(e * jnp.asarray(_W_X_SCALED, e.dtype), -1)
    lu = jnp.sum(jnp.abs(u_est - u_true) * jnp.asarray(W_U, e.dtype), -1)
    per_step = LOSS_C * lx + (1.0 - LOSS_C) * lu
    m = mask.astype(per_step.dtype)
    return jnp.sum(per_step * m) / jnp.maximum(jnp.sum(m), 1.0)


def make_optimizer(cfg: TrainConfig):
    return optax.chain(optax.clip_by_global_norm(cfg.clip_global_norm), optax.rmsprop(cfg.learning_rate))


def make_train_step(net: Lekf, optimizer):
    """Jitted TBPTT step on one chunk: (variables, opt_state, carry, Z, DT,
    valid, X, U) -> (variables, opt_state, carry, loss); Z, DT, valid, X, U
    time-major (T, B, ...)."""

    def loss_fn(params, stats, carry, Z, DT, valid, X, U):
        variables = {k: {"params": params[k], "batch_stats": stats[k]} for k in params}
        carry, outs, new_vars = net.run(variables, carry, Z, DT, valid, train=True)
        loss = wmae(outs["x"], X, outs["u"], U, valid)
        return loss, (carry, {k: new_vars[k]["batch_stats"] for k in new_vars})

    @jax.jit
    def train_step(variables, opt_state, carry, Z, DT, valid, X, U):
        params = {k: v["params"] for k, v in variables.items()}
        stats = {k: v["batch_stats"] for k, v in variables.items()}
        (loss, (carry, stats)), grads = jax.value_and_grad(loss_fn, has_aux=True)(
            params, stats, carry, Z, DT, valid, X, U)
        updates, opt_state = optimizer.update(grads, opt_state, params)
        params = optax.apply_updates(params, updates)
        carry = jax.tree_util.tree_map(jax.lax.stop_gradient, carry)
        return {k: {"params": params[k], "batch_stats": stats[k]} for k in params}, opt_state, carry, loss

    return train_step


def make_eval(net: Lekf):
    """Jitted full-sequence evaluation (running BN averages): -> (loss, outputs)."""

    @jax.jit
    def evaluate(variables, carry, Z, DT, valid, X, U):
        _, outs, _ = net.run(variables, carry, Z, DT, valid, train=False)
        return wmae(outs["x"], X, outs["u"], U, valid), outs

    return evaluate


@dataclass
class TrackSet:
    """Tracks side by side, time-major after ``batch``: X (n, T, 7) scaled truth,
    U (n, T, 3) true inputs, length (n,) valid steps, dt (s)."""
    X: np.ndarray
    U: np.ndarray
    length: np.ndarray
    dt: float


def noisy_batch(ts: TrackSet, idx, R, P0, rng: np.random.Generator):
    """Radar measurements and perturbed initial states for the tracks ``idx``:
    returns x0 (B, 7), P0 (B, 7, 7), Z, DT, valid, X, U (time-major)."""
    X = ts.X[idx]
    U = ts.U[idx]
    b, T = X.shape[:2]
    sig = np.sqrt(np.diag(R))
    Z = X[..., : gm.N_Z] + sig * rng.standard_normal((b, T, gm.N_Z))
    valid = np.arange(T)[None, :] < ts.length[idx][:, None]
    # initial estimate at the first radar epoch: truth + N(0, P0), chi = 0
    x0 = X[:, 0] + rng.standard_normal((b, gm.N_X)) * np.sqrt(np.diag(P0))
    x0[:, 6] = 0.0
    DT = np.full((T, b), ts.dt)
    DT[0] = 0.0                     # the initial estimate is at the first radar epoch
    tm = lambda a: np.swapaxes(a, 0, 1).astype(np.float32)      # noqa: E731
    return (x0.astype(np.float32), np.repeat(P0[None], b, 0).astype(np.float32), tm(Z), DT.astype(np.float32),
            valid.T, tm(X), tm(U))


def train(net: Lekf, variables, train_set: TrackSet, val_set: TrackSet, cfg: TrainConfig, P0,
          log=print, time_limit_s: float | None = None):
    """Train the L-EKF; returns (variables, history). History per epoch:
    train loss (mean over chunks), validation loss (full tracks, fresh noise
    of a fixed seed), wall time."""
    rng = np.random.default_rng(cfg.seed)
    optimizer = make_optimizer(cfg)
    opt_state = optimizer.init({k: v["params"] for k, v in variables.items()})
    step = make_train_step(net, optimizer)
    evaluate = make_eval(net)
    n = len(train_set.length)
    history = []
    t_start = time.monotonic()
    val = noisy_batch(val_set, np.arange(len(val_set.length)), np.asarray(net.R), P0, np.random.default_rng(cfg.seed + 1))
    for epoch in range(cfg.epochs):
        order = rng.permutation(n)
        losses = []
        for b0 in range(0, n - cfg.batch + 1, cfg.batch):
            idx = order[b0: b0 + cfg.batch]
            idx = idx[np.argsort(train_set.length[idx])]
            x0, P0b, Z, DT, valid, X, U = noisy_batch(train_set, idx, np.asarray(net.R), P0, rng)
            carry = net.init_carry(x0, P0b)
            T = int(train_set.length[idx].max())
            for c0 in range(0, T, cfg.chunk):
                sl = slice(c0, min(c0 + cfg.chunk, T))
                if sl.stop - sl.start < cfg.chunk:        # keep one compiled shape: pad the last chunk
                    pad = cfg.chunk - (sl.stop - sl.start)
                    args = [np.concatenate([a[sl], np.repeat(a[sl.stop - 1: sl.stop], pad, 0)]) for a in (Z, DT, X, U)]
                    v = np.concatenate([valid[sl], np.zeros((pad,) + valid.shape[1:], bool)])
                    Zc, DTc, Xc, Uc = args
                else:
                    Zc, DTc, Xc, Uc, v = Z[sl], DT[sl], X[sl], U[sl], valid[sl]
                if not v.any():
                    break
                variables, opt_state, carry, loss = step(variables, opt_state, carry, Zc, DTc, v, Xc, Uc)
                losses.append(float(loss))
            if time_limit_s is not None and time.monotonic() - t_start > time_limit_s:
                break
        x0, P0b, Z, DT, valid, X, U = val
        val_loss = float(evaluate(variables, net.init_carry(x0, P0b), Z, DT, valid, X, U)[0])
        history.append({"epoch": epoch + 1, "train_loss": float(np.mean(losses)) if losses else float("nan"),
                        "val_loss": val_loss, "wall_s": time.monotonic() - t_start})
        log(f"epoch {epoch + 1:3d}  train {history[-1]['train_loss']:.3f}  val {val_loss:.3f}  "
            f"({history[-1]['wall_s']:.0f} s)")
        if time_limit_s is not None and time.monotonic() - t_start > time_limit_s:
            break
    return variables, history


def init_carry_for(net: Lekf, x0, P0) -> LekfCarry:
    return net.init_carry(x0, P0)
