"""The error-state layout, defined once, by block name.

Blocks (frame, unit):
  att  attitude error phi, ENU, rad      (C_est = (I - [phi x]) C_true)
  vel  velocity error, ENU, m/s
  pos  position error, ENU, m
  bg   gyro bias error, body, rad/s
  ba   accelerometer bias error, body, m/s^2
  gm   first-order Markov gyro drift error, body, rad/s (seed 000 eqs. 14-15)
  clk  receiver clock bias (m) and drift (m/s) error (seed 004 eqs. 1-4)
  sg   gyro scale-factor error, body, dimensionless (omega_meas = (1 + sg) omega + bg)
  sa   accelerometer scale-factor error, body, dimensionless (f_meas = (1 + sa) f + ba)
  lev  elastic lever-arm modal coordinates q (3) and rates q' (3) (seed 000 eqs. 9-13)
Every error is estimate minus truth. Other modules ask the layout for slices
(``layout.sl("vel")``) and never compute indices themselves.
"""
from __future__ import annotations

from dataclasses import dataclass

BLOCK_SIZES = {"att": 3, "vel": 3, "pos": 3, "bg": 3, "ba": 3, "gm": 3, "clk": 2, "sg": 3, "sa": 3, "lev": 6}
# Blocks that carry a nominal value besides the navigation state (NavState.extra).
EXTRA_BLOCKS = ("gm", "clk", "sg", "sa", "lev")


@dataclass(frozen=True)
class StateLayout:
    names: tuple[str, ...]

    def __post_init__(self):
        for required in ("att", "vel", "pos"):
            if required not in self.names:
                raise ValueError(f"state blocks must include '{required}', got {self.names}")
        unknown = [n for n in self.names if n not in BLOCK_SIZES]
        if unknown:
            raise ValueError(f"unknown state blocks {unknown}; known: {sorted(BLOCK_SIZES)}")
        if len(set(self.names)) != len(self.names):
            raise ValueError(f"duplicate state blocks in {self.names}")

    @property
    def dim(self) -> int:
        return sum(BLOCK_SIZES[n] for n in self.names)

    def sl(self, name: str) -> slice:
        start = 0
        for n in self.names:
            if n == name:
                return slice(start, start + BLOCK_SIZES[n])
            start += BLOCK_SIZES[n]
        raise KeyError(f"state block '{name}' not in layout {self.names}")

    def has(self, name: str) -> bool:
        return name in self.names

    def describe(self) -> list[str]:
        """Block names with sizes, e.g. ['att:3', 'vel:3', ...] (NavState.state_blocks)."""
        return [f"{n}:{BLOCK_SIZES[n]}" for n in self.names]


INS_15 = StateLayout(("att", "vel", "pos", "bg", "ba"))
TIGHT_17 = StateLayout(("att", "vel", "pos", "bg", "ba", "clk"))        # seed 004
INS_21_SF = StateLayout(("att", "vel", "pos", "bg", "ba", "sg", "sa"))  # 15 + scale factors
ELASTIC_24 = StateLayout(("att", "vel", "pos", "bg", "gm", "ba", "lev"))  # seed 000 eq. 15
