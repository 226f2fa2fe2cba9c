"""Parameters declared once (STYLE 7, the navigation2 pattern).

A :class:`ParamSpec` names one parameter with its type, default, range and
description. The same declaration
  * builds the typed, frozen configuration objects (``FilterConfig`` and the
    per-source parameter objects),
  * validates scenario files (``check`` names the field and coerces an
    integer where a float is expected),
  * declares the node's ROS parameters with descriptors (``ros_util.declare``).
No rclpy here.
"""
from __future__ import annotations

import math

import numpy as np
from dataclasses import dataclass, field
from typing import Any


class ConfigError(ValueError):
    """A configuration field is missing or invalid; the message names it."""


FLOAT, INT, BOOL, STR, FLOATS, STRS = "float", "int", "bool", "str", "float[]", "str[]"


@dataclass(frozen=True)
class ParamSpec:
    """One parameter. ``type`` is one of FLOAT, INT, BOOL, STR, FLOATS (a
    fixed-length vector when ``length`` is set) or STRS. ``lo``/``hi`` bound
    every element (inclusive; ``lo_open``/``hi_open`` make them strict),
    ``choices`` restricts strings. ``updatable``: a time-stamped model update
    (``core.model_update``) may change it while the filter runs."""
    name: str
    type: str
    default: Any
    description: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    length: int | None = None
    choices: tuple[str, ...] | None = None
    updatable: bool = False
    extra: dict = field(default_factory=dict, compare=False)

    def check(self, value, where: str = ""):
        """The value coerced to this parameter's type (int -> float, list ->
        tuple); ConfigError naming the field otherwise."""
        name = f"{where}{self.name}"
        t = self.type
        if t == FLOAT:
            return self._number(value, name)
        if t == INT:
            if isinstance(value, bool) or not isinstance(value, int):
                raise ConfigError(f"{name}: expected an integer, got {value!r}")
            self._range(float(value), name)
            return int(value)
        if t == BOOL:
            if not isinstance(value, bool):
                raise ConfigError(f"{name}: expected true or false, got {value!r}")
            return value
        if t == STR:
            if not isinstance(value, str):
                raise ConfigError(f"{name}: expected a string, got {value!r}")
            if self.choices is not None and value not in self.choices:
                raise ConfigError(f"{name}: expected one of {list(self.choices)}, got {value!r}")
            return value
        if t == FLOATS:
            if not isinstance(value, (list, tuple, np.ndarray)):
                raise ConfigError(f"{name}: expected a list of numbers, got {value!r}")
            if self.length is not None and len(value) != self.length:
                raise ConfigError(f"{name}: expected {self.length} numbers, got {list(value)!r}")
            return tuple(self._number(v, name) for v in value)
        if t == STRS:
            if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
                raise ConfigError(f"{name}: expected a list of strings, got {value!r}")
            if self.choices is not None:
                bad = [v for v in value if v not in self.choices]
                if bad:
                    raise ConfigError(f"{name}: unknown {bad}; known: {list(self.choices)}")
            return tuple(value)
        raise ConfigError(f"{name}: unknown parameter type {t!r}")

    def _number(self, value, name: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{name}: expected a number, got {value!r}")
        x = float(value)
        if not math.isfinite(x):
            raise ConfigError(f"{name}: expected a finite number, got {value!r}")
        self._range(x, name)
        return x

    def _range(self, x: float, name: str) -> None:
        if self.lo is not None and (x < self.lo or (self.lo_open and x == self.lo)):
            raise ConfigError(f"{name}: must be {'>' if self.lo_open else '>='} {self.lo:g}, got {x:g}")
        if self.hi is not None and (x > self.hi or (self.hi_open and x == self.hi)):
            raise ConfigError(f"{name}: must be {'<' if self.hi_open else '<='} {self.hi:g}, got {x:g}")

    def ros_default(self):
        """The default as a ROS parameter value (tuples -> lists)."""
        return list(self.default) if isinstance(self.default, tuple) else self.default

    def range_text(self) -> str:
        parts = []
        if self.lo is not None:
            parts.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
        if self.hi is not None:
            parts.append(f"{'<' if self.hi_open else '<='} {self.hi:g}")
        if self.choices:
            parts.append("one of " + ", ".join(self.choices))
        return "; ".join(parts)


def positive(name, type_, default, description, **kw) -> ParamSpec:
    """A parameter that must be > 0 (every element)."""
    return ParamSpec(name, type_, default, description, lo=0.0, lo_open=True, **kw)


def nonneg(name, type_, default, description, **kw) -> ParamSpec:
    return ParamSpec(name, type_, default, description, lo=0.0, **kw)


def check_all(specs, values: dict, where: str = "") -> dict:
    """Coerced values for every spec (missing ones take the default);
    unknown keys are refused with a did-you-mean suggestion."""
    by_name = {s.name: s for s in specs}
    unknown = sorted(set(values) - set(by_name))
    if unknown:
        raise ConfigError(f"{where}{unknown[0]}: unknown field{suggest(unknown[0], by_name)}")
    return {s.name: s.check(values[s.name], where) if s.name in values else s.default for s in specs}


def suggest(name: str, known) -> str:
    """'; did you mean 'x'?' for the closest known name, or ''."""
    import difflib
    best = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    return f" (did you mean '{best[0]}'?)" if best else f" (known: {', '.join(sorted(known))})"
