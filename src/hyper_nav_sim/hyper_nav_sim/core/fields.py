"""Unknown-field errors with a did-you-mean suggestion, shared by every
scenario block validator (``scenario.py`` and the model blocks' ``from_config``).

    >>> unknown_field("graph.", "real_time_facter", {"real_time_factor", "qos_depth"})
    "graph.real_time_facter: unknown field; did you mean 'real_time_factor'?"

Without a close match the message lists the known names instead.
"""
from __future__ import annotations

import difflib
from typing import Iterable


def suggestion(key: str, allowed: Iterable[str]) -> str | None:
    """The allowed name closest to ``key`` (difflib ratio >= 0.6), or None."""
    match = difflib.get_close_matches(str(key), sorted(map(str, allowed)), n=1, cutoff=0.6)
    return match[0] if match else None


def unknown_field(path: str, key, allowed: Iterable[str]) -> str:
    """Message for an unknown field ``path + key`` (``path`` ends with '.' or is empty)."""
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
