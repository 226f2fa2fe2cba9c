"""The error-state layout, defined once, by block name.

A layout is an ordered tuple of registered block names (``core.blocks``):
the navigation blocks ``att vel pos`` first, then any of
  bg   gyro bias error, body, rad/s
  ba   accelerometer bias error, body, m/s^2
  gm   first-order Markov gyro drift error, body, rad/s (seed 000 eqs. 14-15)
  clk  receiver clock bias (m) and drift (m/s) error (seed 004 eqs. 1-4)
  sg   gyro scale-factor error, body (omega_meas = (1 + sg) omega + bg)
  sa   accelerometer scale-factor error, body (f_meas = (1 + sa) f + ba)
  lev  elastic lever-arm modal coordinates q (3) and rates q' (3) (seed 000 eqs. 9-13)
Every error is estimate minus truth. Other modules ask the layout for slices
(``layout.sl("vel")``) and never compute indices themselves. The nominal
values of the non-navigation blocks are one vector in the same order
(``layout.value_sl(name)``), so an error estimate dx injects into them as
``values - dx[layout.nav_dim:]``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

from .blocks import NAV_BLOCKS, REGISTRY


@dataclass(frozen=True)
class StateLayout:
    names: tuple[str, ...]
    _slices: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        names = tuple(self.names)
        object.__setattr__(self, "names", names)
        unknown = [n for n in names if n not in REGISTRY]
        if unknown:
            raise ValueError(f"unknown state blocks {unknown}; known: {sorted(REGISTRY)}")
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate state blocks in {list(names)}")
        if names[:3] != NAV_BLOCKS:
            raise ValueError(f"state blocks must start with {list(NAV_BLOCKS)}, got {list(names)}")
        sl, start = {}, 0
        for n in names:
            sl[n] = slice(start, start + REGISTRY[n].size)
            start += REGISTRY[n].size
        object.__setattr__(self, "_slices", sl)

    @cached_property
    def dim(self) -> int:
        return sum(REGISTRY[n].size for n in self.names)

    @property
    def nav_dim(self) -> int:
        """Size of the navigation part (att, vel, pos): 9."""
        return 9

    @property
    def blocks(self):
        """The block objects, in layout order."""
        return tuple(REGISTRY[n] for n in self.names)

    @cached_property
    def value_blocks(self):
        """The non-navigation blocks, whose nominal values the filter carries."""
        return tuple(REGISTRY[n] for n in self.names[3:])

    @property
    def value_dim(self) -> int:
        return self.dim - self.nav_dim

    def sl(self, name: str) -> slice:
        try:
            return self._slices[name]
        except KeyError:
            raise KeyError(f"state block '{name}' not in layout {list(self.names)}") from None

    def value_sl(self, name: str) -> slice:
        """Slice of a non-navigation block in the nominal value vector."""
        s = self.sl(name)
        return slice(s.start - self.nav_dim, s.stop - self.nav_dim)

    def has(self, name: str) -> bool:
        return name in self._slices

    def start(self, name: str) -> int:
        """First index of a block, -1 when the layout has none (compiled models' column arguments)."""
        s = self._slices.get(name)
        return -1 if s is None else s.start

    def describe(self) -> list[str]:
        """Block names with sizes, e.g. ['att:3', 'vel:3', ...] (NavState.state_blocks)."""
        return [f"{n}:{REGISTRY[n].size}" for n in self.names]


INS_15 = StateLayout(("att", "vel", "pos", "bg", "ba"))
TIGHT_17 = StateLayout(("att", "vel", "pos", "bg", "ba", "clk"))        # seed 004
INS_21_SF = StateLayout(("att", "vel", "pos", "bg", "ba", "sg", "sa"))  # 15 + scale factors
ELASTIC_24 = StateLayout(("att", "vel", "pos", "bg", "gm", "ba", "lev"))  # seed 000 eq. 15
