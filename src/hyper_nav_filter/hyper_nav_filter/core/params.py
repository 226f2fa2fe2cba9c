"""Parameters declared once (STYLE 7, the navigation2 pattern).

A :class:`ParamSpec` names one parameter with its type, default, range and
description. The same declaration
  * builds the typed, frozen configuration objects (``FilterConfig`` and the
    per-source parameter objects),
  * validates scenario files (``check`` names the field and coerces an
    integer where a float is expected),
  * declares the node's ROS parameters with descriptors (``ros_util.declare``).

Two conveniences for data from outside the project (datasheets, other
filters' configuration files), both declared, not coded:
  * a 3-vector parameter (``length=3``) takes a single number for every axis;
  * an :class:`Alias` gives the same quantity in another unit
    (``accel_vrw_mps_per_sqrt_hr`` for ``accel_vrw_ug_per_sqrt_hz``): a
    scenario or setup file may give either, never both; the value is
    converted once, into the declared unit, by ``check_all``.
``optional`` parameters take NaN for "not set" (their description says what
then applies).
No rclpy here.
"""
from __future__ import annotations

import difflib
import math

import numpy as np
from dataclasses import dataclass, field
from typing import Any, Iterable


class ConfigError(ValueError):
    """A configuration field is missing or invalid; the message names it."""


FLOAT, INT, BOOL, STR, FLOATS, STRS = "float", "int", "bool", "str", "float[]", "str[]"


class _Required:
    """The default of a field a file must give (:data:`REQUIRED`)."""

    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED = _Required()      # default of a field without a default: a scenario file must give it


@dataclass(frozen=True)
class ParamSpec:
    """One parameter. ``type`` is one of FLOAT, INT, BOOL, STR, FLOATS (a
    fixed-length vector when ``length`` is set) or STRS. ``lo``/``hi`` bound
    every element (inclusive; ``lo_open``/``hi_open`` make them strict),
    ``choices`` restricts strings. ``updatable``: a time-stamped model update
    (``core.model_update``) may change it while the filter runs.
    ``interval``: a range error states the interval ("expected a number in
    [0, 1e+06]", "expected an integer in [2, 1000]") instead of the bound
    crossed; ``quantity`` names what the value is in a range error ("a
    standard deviation must be > 0"); ``rule``: a condition
    on the whole checked value that no range says (a unit quaternion),
    returning the error text or None. ``default`` :data:`REQUIRED`: a file
    must give the field (``required``). ``broadcast=False``: a vector
    must be given element by element (a list of ``length`` numbers)."""
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
    aliases: tuple = ()            # Alias: the same quantity in other units (scenario/setup files only)
    optional: bool = False         # NaN (every element) = not set
    interval: bool = False
    quantity: str = ""
    broadcast: bool = True         # FLOATS of a length: one number stands for every element
    rule: Any = field(default=None, compare=False)

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def check(self, value, where: str = ""):
        """The value coerced to this parameter's type (int -> float, list ->
        tuple); ConfigError naming the field otherwise."""
        name = f"{where}{self.name}"
        value = self._check(value, name)
        if self.rule is not None:
            why = self.rule(value)
            if why:
                raise ConfigError(f"{name}: {why}")
        return value

    def _check(self, value, name: str):
        t = self.type
        if t == FLOAT:
            return self._number(value, name)
        if t == INT:
            if isinstance(value, bool) or not isinstance(value, int):
                raise ConfigError(f"{name}: expected an integer, got {value!r}")
            self._range(value, name)
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
            if self.length is not None and self.broadcast and _is_number(value):
                value = [value] * self.length           # one number for every axis
            if not isinstance(value, (list, tuple, np.ndarray)):
                what = (f"a number or a list of {self.length} numbers" if self.length and self.broadcast else
                        f"a list of {self.length} numbers" if self.length else "a list of numbers")
                raise ConfigError(f"{name}: expected {what}, got {value!r}")
            if self.length is not None and len(value) != self.length:
                what = f"{self.length} numbers" if self.broadcast else f"a list of {self.length} numbers"
                raise ConfigError(f"{name}: expected {what}, got {list(value)!r}")
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
        if not _is_number(value):
            raise ConfigError(f"{name}: expected a number, got {value!r}")
        x = float(value)
        if math.isnan(x) and self.optional:
            return math.nan             # one object: configurations with "not set" compare and hash alike
        if not math.isfinite(x):
            raise ConfigError(f"{name}: expected a finite number, got {value!r}")
        self._range(x, name)
        return x

    def _range(self, x, name: str) -> None:
        low = self.lo is not None and (x < self.lo or (self.lo_open and x == self.lo))
        high = self.hi is not None and (x > self.hi or (self.hi_open and x == self.hi))
        if not (low or high):
            return
        if self.interval and self.lo is not None and self.hi is not None:
            span = f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}{')' if self.hi_open else ']'}"
            what = "an integer" if self.type == INT else "a number"
            raise ConfigError(f"{name}: expected {what} in {span}, got {x!r}")
        if low:
            bound = f"{'>' if self.lo_open else '>='} {self.lo:g}"
        else:
            bound = f"{'<' if self.hi_open else '<='} {self.hi:g}"
        what = f"{self.quantity} must be" if self.quantity else "must be"
        raise ConfigError(f"{name}: {what} {bound}, got {x!r}")

    def is_set(self, value) -> bool:
        """False for an optional parameter left at NaN (every element)."""
        return not (self.optional and bool(np.all(np.isnan(np.asarray(value, float)))))

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


def _is_number(x) -> bool:
    return isinstance(x, (int, float, np.floating, np.integer)) and not isinstance(x, bool)


@dataclass(frozen=True)
class Alias:
    """``name`` gives the quantity of a parameter in another unit (or
    representation): ``to_declared`` converts a checked value (float or
    tuple, as ``spec`` checks it) into the declared parameter's unit."""
    spec: ParamSpec
    to_declared: Any

    @property
    def name(self) -> str:
        return self.spec.name


def unit_alias(declared: ParamSpec, name: str, factor: float, unit: str) -> Alias:
    """An alias in another unit: declared = factor * alias (every element);
    the range scales with it."""
    scale = (lambda b: None if b is None else b / factor)
    spec = ParamSpec(name, declared.type, declared.default, f"{declared.description.split(' (')[0]} ({unit}); "
                     f"alternative to {declared.name}", lo=scale(declared.lo), hi=scale(declared.hi),
                     lo_open=declared.lo_open, hi_open=declared.hi_open, length=declared.length,
                     optional=declared.optional)
    conv = (lambda v: tuple(factor * x for x in v)) if declared.type == FLOATS else (lambda v: factor * v)
    return Alias(spec, conv)


def with_aliases(spec: ParamSpec, *units) -> ParamSpec:
    """``spec`` with unit aliases: each (name, factor, unit) as in :func:`unit_alias`."""
    import dataclasses
    return dataclasses.replace(spec, aliases=spec.aliases + tuple(unit_alias(spec, *u) for u in units))


def resolve_aliases(specs, values: dict, where: str = "") -> dict:
    """``values`` with every alias replaced by its declared parameter
    (checked, converted); giving a quantity twice is an error naming both."""
    out = dict(values)
    for s in specs:
        given = [a for a in s.aliases if a.name in out]
        if not given:
            continue
        names = ([s.name] if s.name in out else []) + [a.name for a in given]
        if len(names) > 1:
            raise ConfigError(f"{where}{names[1]}: the same quantity as {names[0]}; give only one of "
                              f"{', '.join(names)}")
        a = given[0]
        out[s.name] = a.to_declared(a.spec.check(out.pop(a.name), where))
    return out


def positive(name, type_, default, description, **kw) -> ParamSpec:
    """A parameter that must be > 0 (every element)."""
    return ParamSpec(name, type_, default, description, lo=0.0, lo_open=True, **kw)


def nonneg(name, type_, default, description, **kw) -> ParamSpec:
    return ParamSpec(name, type_, default, description, lo=0.0, **kw)


def kind_of(default) -> str | None:
    """The parameter type of a field declared by its default (a dataclass field's: bool, int, float, str,
    tuple of floats); None for another."""
    return (BOOL if isinstance(default, bool) else INT if isinstance(default, int) else
            FLOAT if isinstance(default, float) else STR if isinstance(default, str) else
            FLOATS if isinstance(default, tuple) else None)


def checked(name: str, value, type_: str, *, error: type[Exception] = ConfigError, **rules):
    """One value of a block its own parser reads key by key (the flight, the
    GNSS receiver, the world, the elastic lever arm, the virtual receiver, the
    magnetometer, the geomagnetic map), checked by the same rule as a
    declared parameter: ``ParamSpec(name, type_, ..., **rules)`` (``lo``,
    ``hi``, ``lo_open``, ``hi_open``, ``interval``, ``length``,
    ``broadcast``, ``choices``); the error names the field and is raised as
    ``error`` (the caller's own error type)."""
    try:
        return ParamSpec(name, type_, None, "", **rules).check(value)
    except ConfigError as exc:
        if error is ConfigError:
            raise
        raise error(str(exc)) from None


def number(name: str, value, lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
           hi_open: bool = False, interval: bool = False, error: type[Exception] = ConfigError) -> float:
    """A finite number (``lo``/``hi`` inclusive unless open): :func:`checked` of a FLOAT."""
    return checked(name, value, FLOAT, error=error, lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open,
                   interval=interval)


def check_all(specs, values: dict, where: str = "") -> dict:
    """Coerced values for every spec (missing ones take the default);
    unknown keys are refused with a did-you-mean suggestion."""
    by_name = {s.name: s for s in specs}
    unknown = sorted(set(values) - set(by_name) - {a.name for s in specs for a in s.aliases})
    if unknown:
        known = list(by_name) + [a.name for s in specs for a in s.aliases]
        raise ConfigError(f"{where}{unknown[0]}: unknown field{suggest(unknown[0], known)}")
    values = resolve_aliases(specs, values, where)
    return {s.name: s.check(values[s.name], where) if s.name in values else s.default for s in specs}


# ---- the one did-you-mean of the project: every refused field name goes through ``suggestion`` ----------------
def suggestion(key: str, allowed: Iterable[str]) -> str | None:
    """The allowed name closest to ``key`` (difflib ratio >= 0.6), or None."""
    match = difflib.get_close_matches(str(key), sorted(map(str, allowed)), n=1, cutoff=0.6)
    return match[0] if match else None


def suggest(name: str, known) -> str:
    """" (did you mean 'x'?)" for the closest known name, else " (known: a, b, ...)"."""
    best = suggestion(name, known)
    return f" (did you mean '{best}'?)" if best else f" (known: {', '.join(sorted(map(str, known)))})"


def unknown_field(path: str, key, allowed: Iterable[str]) -> str:
    """Message for an unknown field ``path + key`` (``path`` ends with '.' or is empty)::

        >>> unknown_field("graph.", "real_time_facter", {"real_time_factor", "qos_depth"})
        "graph.real_time_facter: unknown field; did you mean 'real_time_factor'?"

    Without a close match the message lists the known names instead."""
    allowed = sorted(map(str, allowed))
    best = suggestion(key, allowed)
    if best:
        return f"{path}{key}: unknown field; did you mean '{best}'?"
    return f"{path}{key}: unknown field (known: {', '.join(allowed)})"


def check_keys(d: dict, allowed: Iterable[str], path: str) -> None:
    """ValueError naming the first key of ``d`` not in ``allowed``."""
    allowed = set(allowed)
    for key in d:
        if key not in allowed:
            raise ValueError(unknown_field(path, key, allowed))
