"""What a Monte Carlo run feeds the fusion core besides the IMU: the
scenario's declared sources (``filter.sources``), simulated as the nodes
publish them and converted as the fusion node converts them.

  * ``gnss_fix``, ``gnss_vel``: the loosely coupled fixes and velocities
    (``offline_fly.gnss_measurements``, as before);
  * ``gnss_raw`` (tightly coupled): the receiver's raw epochs and broadcast
    ephemerides through the source's own pseudorange core (the fusion
    node's ``gnss_raw`` source object), fed to the engine after each IMU
    sample as the node does;
  * ``baro_height``: the barometer's pressures as the baro node publishes
    them (pressure, variance), through the source's converter (US76
    pressure altitude, sigma through dp/dh, floors and ceilings).

Map matching (``horizontal_fix`` / ``position_fix`` from the geomagnetic
aiding node) is not drawn here: its matcher runs on the filter's own state
in the loop (``hyper_nav_aiding.offline_geomag``, the seed 003
reproduction); a scenario declaring it is refused with a message naming
the source. No rclpy.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

LOOSE = {"gnss_fix": "gnss_pos", "gnss_vel": "gnss_vel"}


def _stamp(t_s: float):
    ns = int(round(t_s * 1e9))
    return SimpleNamespace(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class Feed:
    """The non-IMU inputs of one run, in time order: ``until(engine, t)``
    feeds everything stamped at or before ``t`` (after the IMU sample at
    ``t``), as the engine would receive it."""

    def __init__(self, sc, traj, cfg):
        from hyper_nav_filter.sources import make_sources

        from .. import offline_fly
        from . import simulate
        self.events: list[tuple] = []          # (t_s, order, apply(engine))
        self.hooks = []
        specs = sc.filter_source_specs()
        kinds = {LOOSE[s.type] for s in specs if s.type in LOOSE}
        if kinds:
            for n, m in enumerate(m for m in offline_fly.gnss_measurements(sc, traj) if m.kind in kinds):
                self.events.append((m.t_s, 0, n, lambda eng, m=m: eng.add_measurement(m)))
        for src in make_sources(specs, cfg):
            typ = src.spec.type
            if typ in ("imu", *LOOSE):
                continue
            if typ == "gnss_raw":
                tight = src.tight
                for n, ep in enumerate(simulate.gnss_raw_stream(sc, traj)):
                    def raw(eng, ep=ep, tight=tight):
                        for eph in ep.ephemeris_set:
                            tight.add_ephemeris(eph)
                        tight.add_raw(ep.raw())
                    self.events.append((ep.t_s, 1, n, raw))
                self.hooks.append(lambda eng, tight=tight: tight.feed(eng))
            elif typ == "baro_height":
                from .baro_model import BaroErrors
                t_s, p_pa, _ = simulate.baro_stream(sc, traj)
                ok = np.isfinite(p_pa)
                err = BaroErrors.from_config(sc.data["barometer"], prefix="barometer")
                for n, (t, p) in enumerate(zip(t_s[ok], p_pa[ok])):
                    msg = SimpleNamespace(header=SimpleNamespace(stamp=_stamp(float(t)), frame_id="base_link"),
                                          fluid_pressure=float(p),
                                          variance=float((err.pressure_noise_rel * p) ** 2 + err.pressure_noise_pa ** 2))
                    self.events.append((float(t), 2, n, lambda eng, msg=msg, src=src: src.on_message("main", msg, eng)))
            else:
                raise ValueError(f"filter.sources.{src.spec.id}: type {typ!r} is not drawn in Monte Carlo campaigns "
                                 "(map-matching aids run their matcher in the loop: see repro_seed003)")
        self.events.sort(key=lambda e: e[:3])
        self._j = 0

    def until(self, eng, t_s: float) -> None:
        ev = self.events
        while self._j < len(ev) and ev[self._j][0] <= t_s + 1e-9:
            ev[self._j][3](eng)
            self._j += 1
        for h in self.hooks:
            h(eng)
