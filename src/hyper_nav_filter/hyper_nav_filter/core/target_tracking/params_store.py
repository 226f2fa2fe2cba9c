"""Trained L-EKF parameter sets: ``<name>.npz`` (every array of the flax
variables, keys like ``imn/params/lstm1/hi/kernel``) beside ``<name>.json``
(architecture, training configuration, data seed, tracker configuration,
loss history, figures). Shipped sets live in ``core/tracking/trained/``."""
from __future__ import annotations

import json
import pathlib

import numpy as np
from flax import traverse_util

from hyper_nav_filter.core.target_tracking.lekf import LekfArch

TRAINED_DIR = pathlib.Path(__file__).resolve().parent / "trained"


def resolve(name_or_path: str | pathlib.Path) -> pathlib.Path:
    """Path stem of a parameter set: a shipped name or a path (with or without suffix)."""
    p = pathlib.Path(name_or_path)
    if p.suffix in (".npz", ".json"):
        p = p.with_suffix("")
    if p.with_suffix(".npz").exists():
        return p
    cand = TRAINED_DIR / p.name
    if cand.with_suffix(".npz").exists():
        return cand
    raise FileNotFoundError(f"L-EKF parameter set '{name_or_path}' not found (shipped sets: "
                            f"{sorted(q.stem for q in TRAINED_DIR.glob('*.npz'))})")


def save(stem: str | pathlib.Path, arch: LekfArch, variables: dict, meta: dict) -> pathlib.Path:
    stem = pathlib.Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    flat = traverse_util.flatten_dict(variables, sep="/")
    np.savez_compressed(stem.with_suffix(".npz"), **{k: np.asarray(v, np.float32) for k, v in flat.items()})
    stem.with_suffix(".json").write_text(json.dumps({"arch": arch.as_dict(), **meta}, indent=1, default=_json))
    return stem


def load(name_or_path) -> tuple[LekfArch, dict, dict]:
    """(architecture, variables, metadata) of a parameter set."""
    stem = resolve(name_or_path)
    meta = json.loads(stem.with_suffix(".json").read_text())
    with np.load(stem.with_suffix(".npz")) as z:
        variables = traverse_util.unflatten_dict({k: np.asarray(z[k]) for k in z.files}, sep="/")
    return LekfArch.from_dict(meta["arch"]), variables, meta


def _json(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o))
