"""Time-stamped model updates (issue 9, item 4): new values of updatable
filter fields (``ParamSpec.updatable``, first use: the natural frequencies of
the elastic lever-arm modes re-estimated by an aiding node) that take effect
at their epoch. The fusion engine queues them with the measurements, applies
them in time order and keeps the configuration in force in every snapshot,
so re-processing after a late measurement uses the model of each epoch.
"""
from __future__ import annotations

from dataclasses import dataclass

from .config import PARAM_BY_NAME
from .params import ConfigError


@dataclass(frozen=True)
class ModelUpdate:
    t_s: float                       # epoch from which the values apply (sim time)
    model: str                       # e.g. "lever_arm"
    values: tuple                    # ((field, value), ...), value a float or a tuple
    origin: str = ""
    note: str = ""
    kind: str = "model_update"

    @property
    def fields(self) -> dict:
        return dict(self.values)

    def apply_to(self, kf) -> None:
        """An event that changes the filter's model, not a measurement: the
        engine applies it in time order with the measurements (``FusionEngine._apply``)."""
        kf.apply_model_update(self.fields)

    @classmethod
    def from_arrays(cls, t_s: float, model: str, names, values, origin: str = "", note: str = "") -> "ModelUpdate":
        """From the parallel arrays of hyper_nav_msgs/ModelUpdate: each name is
        a field (``f`` repeated once per element, in order) or an element
        (``f[i]``, all elements of the field given). ConfigError names a bad
        entry."""
        names, values = list(names), [float(v) for v in values]
        if len(names) != len(values):
            raise ConfigError(f"model update: {len(names)} names but {len(values)} values")
        grouped: dict[str, dict[int, float]] = {}
        for name, value in zip(names, values):
            base, idx = name, None
            if name.endswith("]") and "[" in name:
                base, _, rest = name.partition("[")
                try:
                    idx = int(rest[:-1])
                except ValueError:
                    raise ConfigError(f"model update: bad element name {name!r}") from None
            g = grouped.setdefault(base, {})
            g[len(g) if idx is None else idx] = value
        out = []
        for base, elems in grouped.items():
            spec = PARAM_BY_NAME.get(base)
            if spec is None or not spec.updatable:
                updatable = sorted(p for p, s in PARAM_BY_NAME.items() if s.updatable)
                raise ConfigError(f"model update: {base!r} is not an updatable filter field (updatable: {updatable})")
            if spec.length is None:
                if set(elems) != {0}:
                    raise ConfigError(f"model update: {base} takes one value, got {len(elems)}")
                out.append((base, spec.check(elems[0], "model update ")))
            else:
                if sorted(elems) != list(range(spec.length)):
                    raise ConfigError(f"model update: {base} needs all {spec.length} elements, got {sorted(elems)}")
                out.append((base, spec.check([elems[i] for i in range(spec.length)], "model update ")))
        if not out:
            raise ConfigError("model update: no values")
        return cls(float(t_s), str(model), tuple(out), origin, note)
