"""Signal plans and the dual-frequency ionosphere-free combination.

A *signal plan* says, per system, which signals make a satellite's
pseudorange, as a list of choices in priority order: ``"1C+2W"`` is the
ionosphere-free combination of C1C and C2W, ``"1C"`` a single-frequency
pseudorange (the broadcast Klobuchar model then removes the ionosphere).
For each satellite the first choice whose signals all have a valid code
(PR_VALID) is taken, so ``{"G": ["1C+2W", "1C"]}`` uses L1/L2 where both
are tracked and falls back to L1 alone.

Ionosphere-free code combination (first-order ionosphere, I_s = 40.3 TEC / f_s^2;
e.g. RTKLIB manual E.5, Hofmann-Wellenhof et al. 2008 eq. 5.76):

    P_IF = (f1^2 P1 - f2^2 P2) / (f1^2 - f2^2) = a1 P1 - a2 P2,
    a1 = f1^2 / (f1^2 - f2^2),  a2 = f2^2 / (f1^2 - f2^2)

(each P already corrected for its group delay, :mod:`.signal_delays`), with
noise variance a1^2 s1^2 + a2^2 s2^2 (independent signals): x 2.98 in sigma
for GPS L1/L2 with equal noise, x 2.59 for L1/L5, x 2.81 for E1/E5b, x 3.5
for B1I/B3I.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from hyper_nav_gnss.signals import frequency_hz

DEFAULT_PLAN = {"G": ("1C+2W", "1C+2L", "1C+2X", "1C+5Q", "1C+5X", "1C"),
                "E": ("1C+7Q", "1X+7X", "1C+5Q", "1X+5X", "1C", "1X"),
                "C": ("2I+6I", "2I+7I", "2I", "6I")}
SINGLE_FREQUENCY_PLAN = {"G": ("1C",), "E": ("1C", "1X"), "C": ("2I", "6I")}


def parse_plan(plan) -> dict:
    """{system: tuple of tuple(codes)} from {system: ["1C+2W", "1C"]}; errors name the entry."""
    out = {}
    if not isinstance(plan, dict) or not plan:
        raise ValueError(f"signals: expected a mapping system -> list of choices, got {plan!r}")
    for sysc, choices in plan.items():
        if isinstance(choices, str):
            choices = [choices]
        parsed = []
        for ch in choices:
            codes = tuple(str(ch).split("+"))
            if not 1 <= len(codes) <= 2 or any(len(c) != 2 for c in codes):
                raise ValueError(f"signals.{sysc}: {ch!r} is not a RINEX code ('1C') or a pair ('1C+2W')")
            for c in codes:
                frequency_hz(sysc, c)              # raises for an unknown band
            if len(codes) == 2 and codes[0][0] == codes[1][0]:
                raise ValueError(f"signals.{sysc}: {ch!r} combines two signals of the same band")
            parsed.append(codes)
        out[str(sysc)] = tuple(parsed)
    return out


def iono_free_coefficients(system: str, code1: str, code2: str) -> tuple[float, float]:
    """(a1, a2) of P_IF = a1 P1 - a2 P2."""
    f1, f2 = frequency_hz(system, code1), frequency_hz(system, code2)
    d = f1 * f1 - f2 * f2
    return f1 * f1 / d, f2 * f2 / d


@dataclass(frozen=True)
class Choice:
    """The signals chosen for one satellite of one epoch: channel indices and codes."""
    system: str
    prn: int
    channels: tuple
    codes: tuple

    @property
    def dual(self) -> bool:
        return len(self.codes) == 2


def choose_signals(raw, plan: dict, counters=None) -> list[Choice]:
    """One :class:`Choice` per satellite of ``raw`` (a RawGnssEpoch) whose
    system is in ``plan`` (parsed) and that has the signals of some choice.
    A channel counts when it is ``locked`` (code valid). Epochs without
    signal codes (the simulated receiver's) are read as each system's
    legacy signal."""
    from hyper_nav_gnss.signals import signal_code
    finite_a = np.isfinite(np.asarray(raw.pseudorange_m, float))
    prns_a = np.asarray(raw.prn)
    # consecutive epochs of a file mostly have the same channels: the choice (and the counts it adds) kept
    # per layout (systems, PRNs, codes, lock, finite code) and plan
    key = (id(plan), tuple(raw.system), prns_a.tobytes(), prns_a.dtype.str, tuple(raw.signal),
           np.asarray(raw.locked, bool).tobytes(), finite_a.tobytes())
    got = _CHOICES.get(key)
    if got is not None and got[0] is plan:
        if counters is not None:
            counters.update(got[2])
        return list(got[1])
    local = Counter()
    out = _choose(raw, plan, local, finite_a.tolist(), prns_a.tolist(), signal_code)
    if len(_CHOICES) > 256:
        _CHOICES.clear()
    _CHOICES[key] = (plan, tuple(out), local)
    if counters is not None:
        counters.update(local)
    return out


_CHOICES: dict = {}


def _choose(raw, plan, counters, finite, prns, signal_code) -> list[Choice]:
    by_sat: dict = {}
    sig = raw.signal
    for k, (s, ok) in enumerate(zip(raw.system, raw.locked)):
        if s not in plan:
            if counters is not None:
                counters["signals_system_not_in_plan"] += 1
            continue
        if not ok or not finite[k]:
            continue
        c = sig[k] if sig else ""
        code = (c or signal_code(s, c)) if s in ("G", "E", "C", "J") else c
        by_sat.setdefault((s, int(prns[k])), {}).setdefault(code, k)
    out = []
    for (s, p), codes in by_sat.items():
        for ch in plan[s]:
            if all(c in codes for c in ch):
                out.append(Choice(s, p, tuple(codes[c] for c in ch), ch))
                break
        else:
            if counters is not None:
                counters["satellites_without_planned_signal"] += 1
    return out
