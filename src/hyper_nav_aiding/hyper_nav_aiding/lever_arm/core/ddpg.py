"""DDPG agent of RL-DLAC (seed 000 section III.B.4, Table 3) on flax + optax.

Actor (evaluation and target): 3 -> 30 (ReLU) -> 3 (tanh), the frequency
change in [-1, 1]^3. Critic: Q(s, a), [s, a] (6) -> 30 (ReLU) -> 1 (the paper
gives no critic size; ours mirrors the actor). Table 3: actor learning rate
0.001, critic 0.002, 50 episodes of 5 steps, replay memory 250, soft update
0.01. Not in the paper, our choices: Adam, batch 32, discount 0.9, Gaussian
exploration noise on the action decaying from 0.5 to 0.05 over the episodes,
ten gradient steps per environment step once the memory holds a batch (a step
costs ~1 ms against a filter pass's 0.1-1 s), and
rewards divided by |reward of the initial model| (the scale of r = -|r - r_G|
depends on the GNSS grade; the optimum does not); the initialisation of
Lillicrap et al. (2016). The learned frequencies are
the best state visited (III.B: "from which we can also obtain the learned
optimal state").

Networks are compiled once per process and configuration (``_functions``).
"""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class DDPGConfig:
    actor_lr: float = 0.001          # Table 3
    critic_lr: float = 0.002         # Table 3
    episodes: int = 50               # Table 3, max_episodes
    steps: int = 5                   # Table 3, max_episodes_steps
    memory: int = 250                # Table 3, memory_capacity
    tau: float = 0.01                # Table 3, soft_update
    hidden: int = 30                 # section III.B.4: hidden layer of 30
    batch: int = 32
    gamma: float = 0.9
    noise_start: float = 0.5
    noise_end: float = 0.05
    updates_per_step: int = 10


@functools.lru_cache(maxsize=None)
def _functions(hidden: int, actor_lr: float, critic_lr: float, gamma: float, tau: float):
    """(init, act, update), jitted once per process for a configuration
    (jax, flax and optax are imported here: the module stays light for the
    classical identifiers' worker)."""
    import flax.linen as nn
    import jax
    import jax.numpy as jnp
    import optax

    class Actor(nn.Module):
        hidden: int

        @nn.compact
        def __call__(self, s):
            return jnp.tanh(nn.Dense(3, name="out")(nn.relu(nn.Dense(self.hidden, name="hidden")(s))))


    class Critic(nn.Module):
        hidden: int

        @nn.compact
        def __call__(self, s, a):
            h = nn.relu(nn.Dense(self.hidden, name="hidden")(jnp.concatenate([s, a], axis=-1)))
            return nn.Dense(1, name="out")(h)[..., 0]

    actor, critic = Actor(hidden), Critic(hidden)
    opt_a, opt_c = optax.adam(actor_lr), optax.adam(critic_lr)

    def init(seed: int):
        """Lillicrap et al. (2016) initialisation, drawn with numpy (no
        compilation): hidden layers U(-1/sqrt(fan_in), +), output layers
        U(-3e-3, 3e-3)."""
        g = np.random.default_rng(seed)

        def dense(n_in, n_out, lim):
            return {"kernel": jnp.asarray(g.uniform(-lim, lim, (n_in, n_out)), jnp.float32),
                    "bias": jnp.asarray(g.uniform(-lim, lim, n_out), jnp.float32)}

        pa = {"params": {"hidden": dense(3, hidden, 1 / np.sqrt(3)), "out": dense(hidden, 3, 3e-3)}}
        pc = {"params": {"hidden": dense(6, hidden, 1 / np.sqrt(6)), "out": dense(hidden, 1, 3e-3)}}
        return {"actor": pa, "critic": pc, "actor_t": pa, "critic_t": pc,
                "opt_a": opt_a.init(pa), "opt_c": opt_c.init(pc)}

    @jax.jit
    def act(params, s):
        return actor.apply(params, s)

    @jax.jit
    def update(st, s, a, r, s2, done):
        a2 = actor.apply(st["actor_t"], s2)
        y = r + gamma * (1.0 - done) * critic.apply(st["critic_t"], s2, a2)

        def critic_loss(pc):
            return jnp.mean((critic.apply(pc, s, a) - jax.lax.stop_gradient(y)) ** 2)

        lc, gc = jax.value_and_grad(critic_loss)(st["critic"])
        uc, opt_c_state = opt_c.update(gc, st["opt_c"], st["critic"])
        pc = optax.apply_updates(st["critic"], uc)

        def actor_loss(pa):
            return -jnp.mean(critic.apply(pc, s, actor.apply(pa, s)))

        la, ga = jax.value_and_grad(actor_loss)(st["actor"])
        ua, opt_a_state = opt_a.update(ga, st["opt_a"], st["actor"])
        pa = optax.apply_updates(st["actor"], ua)
        soft = lambda t, p: jax.tree_util.tree_map(lambda x, y: (1 - tau) * x + tau * y, t, p)  # noqa: E731
        return {"actor": pa, "critic": pc, "actor_t": soft(st["actor_t"], pa), "critic_t": soft(st["critic_t"], pc),
                "opt_a": opt_a_state, "opt_c": opt_c_state}, lc, la

    return init, act, update


class ReplayMemory:
    """Ring buffer of (s, a, r, s', done), capacity ``memory`` (Table 3)."""

    def __init__(self, capacity: int):
        self.s = np.zeros((capacity, 3), np.float32)
        self.a = np.zeros((capacity, 3), np.float32)
        self.r = np.zeros(capacity, np.float32)
        self.s2 = np.zeros((capacity, 3), np.float32)
        self.done = np.zeros(capacity, np.float32)
        self.n = 0
        self.capacity = capacity

    def add(self, s, a, r, s2, done) -> None:
        i = self.n % self.capacity
        self.s[i], self.a[i], self.r[i], self.s2[i], self.done[i] = s, a, r, s2, float(done)
        self.n += 1

    def __len__(self) -> int:
        return min(self.n, self.capacity)

    def sample(self, rng: np.random.Generator, batch: int):
        idx = rng.integers(0, len(self), batch)
        return self.s[idx], self.a[idx], self.r[idx], self.s2[idx], self.done[idx]


@dataclass
class DDPGResult:
    freqs_radps: np.ndarray              # best state visited
    reward: float                        # its reward (m, negative)
    episode_rewards: list = field(default_factory=list)      # sum of rewards per episode (m)
    episode_best: list = field(default_factory=list)         # best reward so far after each episode
    n_passes: int = 0
    wall_s: float = 0.0
    cpu_s: float = 0.0


def train(env, cfg: DDPGConfig = DDPGConfig(), seed: int = 0) -> DDPGResult:
    """Run DDPG on ``env`` (a ``LeverArmFrequencyEnv``) for ``cfg.episodes``
    episodes (the environment's deadline, if any, ends it with its exception)."""
    t0, c0 = time.perf_counter(), time.process_time()
    init, act, update = _functions(cfg.hidden, cfg.actor_lr, cfg.critic_lr, cfg.gamma, cfg.tau)
    rng = np.random.default_rng(seed)
    params = init(seed)
    memory = ReplayMemory(cfg.memory)
    scale = max(abs(env.evaluate(env.w_init)), 1e-9)        # reward of the model in force
    out = DDPGResult(env.best_freqs_radps.copy(), env.best_reward)
    for ep in range(cfg.episodes):
        sigma = cfg.noise_start + (cfg.noise_end - cfg.noise_start) * ep / max(cfg.episodes - 1, 1)
        s, _ = env.reset(seed=int(rng.integers(2**31)))
        total = 0.0
        for _ in range(cfg.steps):
            a = np.asarray(act(params["actor"], s[None, :]))[0]
            a = np.clip(a + sigma * rng.standard_normal(3), -1.0, 1.0).astype(np.float32)
            s2, r, term, trunc, _ = env.step(a)
            memory.add(s, a, r / scale, s2, term)
            total += r
            if len(memory) >= cfg.batch:
                for _ in range(cfg.updates_per_step):
                    params, _, _ = update(params, *memory.sample(rng, cfg.batch))
            s = s2
            if term or trunc:
                break
        out.episode_rewards.append(total)
        out.episode_best.append(env.best_reward)
    out.freqs_radps, out.reward = env.best_freqs_radps.copy(), env.best_reward
    out.n_passes, out.wall_s, out.cpu_s = env.n_passes, time.perf_counter() - t0, time.process_time() - c0
    return out
