"""The virtual GNSS node's logic without ROS:

* ``run_virtual_offline``: over recorded messages, (topic, message) pairs in
  the order the node would have received them (a bag's log order), through
  the node's own input handler, to the virtual epochs the live node
  publishes (a graph test compares them);
* ``prepare``: a simulated flight with the receiver's raw epochs, with and
  without the scenario's loss of lock (the unit tests' and the seed 004
  reproduction's input).
"""
from __future__ import annotations

import pathlib
import tempfile
from dataclasses import dataclass

import numpy as np

from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario

from hyper_nav_aiding.virtual_gnss.parameters import VirtualGnssNodeParams
from hyper_nav_aiding.virtual_gnss.input import VirtualGnssInput

SCENARIO = "seed004_virtual"


@dataclass
class Flight:
    """One scenario realisation: truth, IMU and the receiver epochs with and
    without the loss of lock (same noise draws)."""
    sc: object
    traj: object
    imu: object
    epochs_loss: list
    epochs_no_loss: list
    t_loss_s: float


def prepare(seed: int, world: str = "realistic", duration_s: float | None = None,
            scenario: str = SCENARIO, overrides: dict | None = None) -> Flight:
    """Simulate the flight of scenario ``seed``: ``world`` 'realistic' |
    'perfect'; ``overrides``: further dotted scenario fields."""
    over = {"seed": int(seed), "world.model": world, **(overrides or {})}
    if duration_s is not None:
        over["duration_s"] = float(duration_s)
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="seed004_"))
    sc = apply_overrides(load_scenario(scenario), over, tmp)
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    loss = simulate.gnss_raw_stream(sc, traj)
    outages = sc.data["gnss"]["raw"]["lock"]["outages"]
    sc_nl = apply_overrides(sc, {"gnss.raw.lock.outages": []}, tmp)
    no_loss = simulate.gnss_raw_stream(sc_nl, traj)
    return Flight(sc, traj, imu, loss, no_loss, float(min(o[0] for o in outages)) if outages else np.inf)


def run_virtual_offline(records, params: VirtualGnssNodeParams) -> tuple[list, VirtualGnssInput]:
    """[(RawGnssEpoch, elevation, azimuth)] in publication order, and the input handler."""
    inp = VirtualGnssInput(params)
    fused = params.config.position_source == "fused"
    out = []
    for topic, msg in records:
        topic = topic.lstrip("/")
        if topic == "gnss/ephemeris":
            inp.on_ephemeris(msg)
        elif topic == "gnss/raw":
            out += inp.on_raw(msg)[0]
        elif topic == "imu/data_raw":
            out += inp.on_imu(msg)
        elif topic in ("nav/delayed/state", "/nav/delayed/state") and fused:
            out += inp.on_state(msg)
        elif topic == "gnss/fix" and not fused:
            inp.on_fix(msg)
    return out, inp
