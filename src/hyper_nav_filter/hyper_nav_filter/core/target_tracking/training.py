"""End-to-end training of the L-EKF through the filter recursion (seed 002
section 3.1): weighted mean absolute error (section 3.1.3) and RMSprop
(section 3.1.4) with optax.

Sequences: every training track is filtered from a random epoch of its
flight (``random_offsets``; the filter starts there from the truth plus an
error drawn from P0) to its last, in chunks of ``chunk`` steps (the paper's
segments of length 100);
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

from hyper_nav_filter.core.target_tracking import glide_model as gm
from hyper_nav_filter.core.target_tracking.lekf import Lekf

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
    """RMSprop (section 3.1.4) after global-norm clipping; an update whose
    gradient is not finite is skipped (a 20-epoch run went NaN at epoch 13:
    one exploding recursion poisoned every parameter)."""
    return optax.apply_if_finite(optax.chain(optax.clip_by_global_norm(cfg.clip_global_norm),
                                             optax.rmsprop(cfg.learning_rate)), max_consecutive_errors=100)


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


def noisy_batch(ts: TrackSet, idx, R, P0, rng: np.random.Generator, offsets=None):
    """Radar measurements and perturbed initial states for the tracks ``idx``,
    each starting ``offsets[i]`` epochs into its flight (default 0): returns
    x0 (B, 7), P0 (B, 7, 7), Z, DT, valid, X, U (time-major) and the lengths."""
    X = ts.X[idx]
    U = ts.U[idx]
    length = ts.length[idx].copy()
    if offsets is not None:
        T0 = X.shape[1]
        cols = np.minimum(np.arange(T0)[None, :] + offsets[:, None], T0 - 1)
        X = np.take_along_axis(X, cols[..., None], axis=1)
        U = np.take_along_axis(U, cols[..., None], axis=1)
        length = length - offsets
        T = int(length.max())
        X, U = X[:, :T], U[:, :T]
    b, T = X.shape[:2]
    sig = np.sqrt(np.diag(R))
    Z = X[..., : gm.N_Z] + sig * rng.standard_normal((b, T, gm.N_Z))
    valid = np.arange(T)[None, :] < length[:, None]
    # initial estimate at the first radar epoch: truth + N(0, P0), chi = 0
    x0 = X[:, 0] + rng.standard_normal((b, gm.N_X)) * np.sqrt(np.diag(P0))
    x0[:, 6] = 0.0
    DT = np.full((T, b), ts.dt)
    DT[0] = 0.0                     # the initial estimate is at the first radar epoch
    tm = lambda a: np.swapaxes(a, 0, 1).astype(np.float32)      # noqa: E731
    return (x0.astype(np.float32), np.repeat(P0[None], b, 0).astype(np.float32), tm(Z), DT.astype(np.float32),
            valid.T, tm(X), tm(U))


def random_offsets(lengths, chunk: int, rng: np.random.Generator) -> np.ndarray:
    """Start epochs: half of the tracks from their first epoch (the pull-up
    into the glide), the others from an epoch drawn uniformly over the flight
    (leaving at least one chunk). A batch then mixes every phase of flight, so
    BatchNorm's batch statistics at one step are those of the data set (the
    paper's shuffled 100-step segments), not of one phase."""
    off = (rng.random(len(lengths)) * np.maximum(np.asarray(lengths) - chunk, 1)).astype(int)
    return np.where(rng.random(len(lengths)) < 0.5, 0, off)


def train(net: Lekf, variables, train_set: TrackSet, val_set: TrackSet, cfg: TrainConfig, P0,
          log=print, time_limit_s: float | None = None, on_epoch=None):
    """Train the L-EKF (``on_epoch(best_variables, history)`` after each
    epoch, e.g. to checkpoint); returns (variables, history): the variables of the
    epoch with the lowest validation loss (the untrained net, i.e. the EKF,
    counts as epoch 0). History per epoch: train loss (mean over chunks),
    validation loss (whole tracks from their first epoch, noise of a fixed
    seed), wall time."""
    rng = np.random.default_rng(cfg.seed)
    optimizer = make_optimizer(cfg)
    opt_state = optimizer.init({k: v["params"] for k, v in variables.items()})
    step = make_train_step(net, optimizer)
    evaluate = make_eval(net)
    n = len(train_set.length)
    history = []
    t_start = time.monotonic()
    val = noisy_batch(val_set, np.arange(len(val_set.length)), np.asarray(net.R), P0, np.random.default_rng(cfg.seed + 1))

    def val_loss_of(v):
        x0, P0b, Z, DT, valid, X, U = val
        return float(evaluate(v, net.init_carry(x0, P0b), Z, DT, valid, X, U)[0])

    best = (val_loss_of(variables), 0, variables)
    history.append({"epoch": 0, "train_loss": float("nan"), "val_loss": best[0], "wall_s": time.monotonic() - t_start})
    log(f"epoch   0  (untrained = EKF)  val {best[0]:.3f}")
    for epoch in range(cfg.epochs):
        order = rng.permutation(n)
        losses = []
        for b0 in range(0, n - cfg.batch + 1, cfg.batch):
            idx = order[b0: b0 + cfg.batch]
            off = random_offsets(train_set.length[idx], cfg.chunk, rng)
            x0, P0b, Z, DT, valid, X, U = noisy_batch(train_set, idx, np.asarray(net.R), P0, rng, off)
            carry = net.init_carry(x0, P0b)
            T = Z.shape[0]
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
        val_loss = val_loss_of(variables)
        if val_loss < best[0]:
            best = (val_loss, epoch + 1, variables)
        history.append({"epoch": epoch + 1, "train_loss": float(np.mean(losses)) if losses else float("nan"),
                        "val_loss": val_loss, "wall_s": time.monotonic() - t_start})
        log(f"epoch {epoch + 1:3d}  train {history[-1]['train_loss']:.3f}  val {val_loss:.3f}  "
            f"({history[-1]['wall_s']:.0f} s)")
        if on_epoch is not None:
            on_epoch(best[2], history)
        if time_limit_s is not None and time.monotonic() - t_start > time_limit_s:
            break
    log(f"best validation loss {best[0]:.3f} at epoch {best[1]}")
    return best[2], history

