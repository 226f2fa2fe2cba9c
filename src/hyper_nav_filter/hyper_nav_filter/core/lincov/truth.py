"""The truth's error sources for a linear covariance analysis (as data).

The simulated world corrupts the IMU with its own error model
(``hyper_nav_sim.core.imu_model``), which need not be the filter's: a
turn-on bias, first-order Gauss-Markov drifts, a bias-instability Markov
sum, scale factors, misalignments, white noise, quantization. For LinCov
each is one ``TruthSource``: a group of augmented states (a random constant
or a first-order Gauss-Markov process per element) or a white noise, with
the way it enters the sensor's output error (body axes):

  gyro:   d_omega = E_g(w, f) s + n_g     accel: d_f = E_a(w, f) s + n_a
  kind bias          E = I3                      (3 states)
  kind scale         E = diag(w) or diag(f)      (3 states, dimensionless)
  kind misalignment  E[i, k] = w_j for the k-th off-diagonal element (i, j)
                     in the order (0,1) (0,2) (1,0) (1,2) (2,0) (2,1)  (6 states, rad)
  kind white         n with two-sided PSD sigma^2 per axis (no states)
  kind lever_arm     the GNSS antenna lever-arm error (3 states, body m),
                     seen by the measurement models only

``maps_to`` names the filter block role that carries the source's value
(``Block.imu_role``, e.g. a truth gyro bias is what the filter's ``bg``
estimates): the filter's block error is then estimate minus the mapped
truth, and a source with no carrier in the filter's layout is unmodelled
(its whole effect is mismodelling). ``prefer_block`` picks among several
carriers of a role (the Markov drift goes to ``gm`` when the filter has it).

All figures SI: rad/s, m/s^2, dimensionless, rad, m; white sigma is the
square root of the PSD (rad/sqrt(s), m/s/sqrt(s)).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

SENSORS = ("gyro", "accel", "gnss")
OFF_DIAGONAL = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))


def _misalignment_map(x) -> np.ndarray:
    E = np.zeros((3, 6))
    for k, (r, c) in enumerate(OFF_DIAGONAL):
        E[r, k] = x[c]
    return E


@dataclass(frozen=True)
class SourceKind:
    """One kind of truth source as data: its augmented states, its sigma
    elements, where it enters (``imu``: an IMU output term, with
    ``output_map(x)``, 3 x size: the output error per unit of its states at
    the sensor's input x, body rate or specific force, the table of the
    module docstring; ``process_noise``: a white noise on the IMU output, no
    states; ``measurement``: seen by the measurement models only)."""
    size: int
    enters: str
    output_map: object = None
    n_sigma: int | None = None       # sigma elements (default: one per state)


KINDS = {
    "bias": SourceKind(3, "imu", lambda x: np.eye(3)),
    "scale": SourceKind(3, "imu", np.diag),
    "misalignment": SourceKind(6, "imu", _misalignment_map),
    "white": SourceKind(0, "process_noise", n_sigma=3),
    "lever_arm": SourceKind(3, "measurement"),
}
SIZES = {k: v.size for k, v in KINDS.items()}


@dataclass(frozen=True)
class TruthSource:
    name: str                      # the budget's label, e.g. "gyro bias instability"
    sensor: str                    # gyro | accel | gnss
    kind: str                      # bias | scale | misalignment | white | lever_arm
    sigma: np.ndarray              # per element (stationary 1-sigma), or sqrt(PSD) for white
    tau_s: float = math.inf        # correlation time; inf = random constant
    maps_to: str | None = None     # filter imu_role carrying it, or None (unmodelled)
    prefer_block: str | None = None
    group: str | None = None       # budget group (default: name); several sources may share one

    def __post_init__(self):
        if self.kind not in SIZES:
            raise ValueError(f"truth source {self.name!r}: kind {self.kind!r} not in {sorted(SIZES)}")
        if self.sensor not in SENSORS:
            raise ValueError(f"truth source {self.name!r}: sensor {self.sensor!r} not in {SENSORS}")
        kind = KINDS[self.kind]
        k = kind.size if kind.n_sigma is None else kind.n_sigma
        sig = np.broadcast_to(np.asarray(self.sigma, float), (k,)).copy()
        if np.any(~np.isfinite(sig)) or np.any(sig < 0):
            raise ValueError(f"truth source {self.name!r}: sigma must be finite and >= 0, got {sig}")
        object.__setattr__(self, "sigma", sig)
        if not self.tau_s > 0:
            raise ValueError(f"truth source {self.name!r}: tau_s must be > 0")
        if self.group is None:
            object.__setattr__(self, "group", self.name)

    @property
    def size(self) -> int:
        return SIZES[self.kind]

    @property
    def enters(self) -> str:
        """Where the source enters the errors (``SourceKind.enters``)."""
        return KINDS[self.kind].enters

    @property
    def markov(self) -> bool:
        return self.size > 0 and math.isfinite(self.tau_s)


@dataclass(frozen=True)
class TruthModel:
    """The world's error sources and the true initial navigation errors.

    ``init_nav_sigma``: (9,) 1-sigma of the true initial att (rad, ENU),
    vel (m/s) and pos (m) errors of the filter's initial state."""
    sources: tuple[TruthSource, ...]
    init_nav_sigma: np.ndarray
    _slices: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        srcs = tuple(s for s in self.sources if np.any(s.sigma > 0))       # a zero source is no source
        object.__setattr__(self, "sources", srcs)
        object.__setattr__(self, "init_nav_sigma", np.broadcast_to(np.asarray(self.init_nav_sigma, float),
                                                                   (9,)).copy())
        names = [s.name for s in srcs]
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate truth source names in {names}")
        sl, k = {}, 0
        for s in srcs:
            sl[s.name] = slice(k, k + s.size)
            k += s.size
        object.__setattr__(self, "_slices", sl)

    @property
    def dim(self) -> int:
        return sum(s.size for s in self.sources)

    def sl(self, name: str) -> slice:
        return self._slices[name]

    def state_sources(self):
        return [s for s in self.sources if s.size > 0]

    def white(self, sensor: str):
        return [s for s in self.sources if s.enters == "process_noise" and s.sensor == sensor]

    def A(self) -> np.ndarray:
        """Self-dynamics of the source states (p x p): -1/tau per Markov element."""
        A = np.zeros((self.dim, self.dim))
        for s in self.state_sources():
            if s.markov:
                i = self.sl(s.name)
                A[i, i] = -np.eye(s.size) / s.tau_s
        return A

    def P0(self, source: TruthSource) -> np.ndarray:
        """Initial (stationary) covariance of one source's states, p x p."""
        P = np.zeros((self.dim, self.dim))
        i = self.sl(source.name)
        P[i, i] = np.diag(source.sigma**2)
        return P

    def E(self, omega_b_radps, f_b_mps2):
        """(E_g, E_a), each 3 x p: the gyro and accelerometer output errors per
        unit of the source states at body rate w and specific force f."""
        Eg, Ea = np.zeros((3, self.dim)), np.zeros((3, self.dim))
        for s in self.state_sources():
            if s.enters != "imu" or s.sensor not in ("gyro", "accel"):
                continue
            output_map = KINDS[s.kind].output_map
            E = Eg if s.sensor == "gyro" else Ea
            E[:, self.sl(s.name)] = output_map(np.asarray(omega_b_radps if s.sensor == "gyro" else f_b_mps2, float))
        return Eg, Ea

    def carrier_map(self, layout) -> np.ndarray:
        """P_v ((n - 9) x p): the filter blocks' true values from the source
        states (block error = estimate - P_v s). A source maps to the first
        block whose ``imu_role`` is its ``maps_to`` (``prefer_block`` first)."""
        nv = layout.value_dim
        Pv = np.zeros((nv, self.dim))
        for s in self.state_sources():
            if s.maps_to is None:
                continue
            carriers = [b.name for b in layout.value_blocks if b.imu_role == s.maps_to]
            if not carriers:
                continue
            name = s.prefer_block if s.prefer_block in carriers else carriers[0]
            block = layout.value_sl(name)
            if block.stop - block.start != s.size:
                continue
            Pv[block, self.sl(s.name)] += np.eye(s.size)
        return Pv
