"""Sensor streams of a commanded flight, drawn as it is flown (issue 36).

A flight steered live (``commanded_flight.CommandedFlight``) exists only up
to ``flown_s``, so its sensors cannot be simulated for the whole flight
before it starts as the scheduled flights' are (``simulate.imu_stream``...).
These generators draw each sensor's samples as the flight advances, with a
cut that never depends on how far or how often it was advanced: the live
sensor nodes (each flying its own mirror of the truth node's flight,
``nodes.flight_mirror``) and the offline loop
(``hyper_nav_guidance.closed_loop.fly_on_navigation``) call them at
different moments and get the same samples bit for bit.

* ``FlownImu``: the exact increments of the flight
  (``DynamicTrajectory.imu_increments``, Gauss-Legendre over each interval)
  corrupted by the scenario's IMU error model as one continuous process
  (``imu_model.ImuErrorState``, stream ``imu``), drawn one command step at a
  time: the samples ending in ((j-1) h, j h] (h = ``flight.step_s``) in one
  call of ``corrupt_increments``, whatever the flight's progress.
* ``FlownFixes``: loosely coupled fixes (``gnss_model.simulate_fixes``,
  antenna truth plus white noise, stream ``gnss``) one epoch at a time,
  drawn for every epoch and dropped inside ``gnss.outages_s`` (and any
  outages given).
* ``FlownRaw``: the raw-GNSS receiver (``gnss.raw``: broadcast-ephemeris
  constellation, the scenario's world, the receiver's lock model and
  least-squares fix; stream ``gnss_raw``), one epoch at a time
  (``ReceiverRun(lazy=True)``: each epoch's antenna truth taken when the
  flight is flown ``ANTENNA_DIFF_S`` past it); the epochs inside the outages
  given are computed with every satellite's lock lost (the receiver's own
  blackout: no measurement, no fix, and reacquisition after it as its lock
  model says).
* ``FlownMag``: the WMM field (``mag_model.simulate_magnetometer_T``,
  stream ``mag``) one epoch at a time.

What these do not simulate on a commanded flight is refused at construction
with the reason (ValueError naming the block): the elastic lever arm and its
load sensor (seed 000), the receiver's tracking loops (``gnss.raw.tracking``), a white map
error of the magnetometer, the barometer and the radar
(``refuse_commanded``). Those models take the whole trajectory at once.
"""
from __future__ import annotations

import math

import numpy as np

from .gnss_model import parse_outages, simulate_fixes
from .imu_model import ImuErrors, ImuErrorState, corrupt_increments, imu_epochs
from .mag_model import MagnetometerErrors, simulate_magnetometer_T

_EPS = 1e-9


def _not_supported(what: str) -> ValueError:
    return ValueError(f"{what} is not simulated on a commanded flight (issue 36: a guidance: block with a "
                      f"flight: block): its model takes the whole trajectory before the flight starts; "
                      f"remove it or the guidance: block")


def refuse_commanded(sc, what: str) -> None:
    """A sensor simulated from the whole trajectory at once refuses a commanded flight (ValueError)."""
    from .commanded_flight import is_commanded
    if is_commanded(sc):
        raise _not_supported(what)


class _FlownEpochs:
    """The stamps ``t_s`` a stream draws on ``flight`` and its cursor ``k`` (the next stamp to draw);
    a stamp is due once the flight is ``lead_s`` past it."""
    lead_s = 0.0

    def _follow(self, flight, t_s) -> None:
        self.flight, self.t_s, self.k = flight, t_s, 0

    @property
    def done(self) -> bool:
        """Every stamp the flight will have is drawn."""
        f = self.flight
        return self.k >= len(self.t_s) or (f.finished and self.t_s[self.k] + self.lead_s > f.flown_s + _EPS)

    def _due(self, t_max: float):
        """The indices of the stamps <= ``t_max`` not drawn yet, the cursor moved past each."""
        while self.k < len(self.t_s) and self.t_s[self.k] <= t_max + _EPS:
            self.k += 1
            yield self.k - 1


class FlownImu(_FlownEpochs):
    """IMU increments of a commanded flight, one command step at a time (module doc)."""

    def __init__(self, sc, flight):
        la = sc.data.get("lever_arm") or {}
        if la.get("enabled", False):
            raise _not_supported("lever_arm (the elastic lever arm and its load sensor)")
        self._follow(flight, imu_epochs(sc["duration_s"], sc["imu.rate_hz"]))
        self.dt_s = 1.0 / sc["imu.rate_hz"]
        self.errors = ImuErrors.from_scenario(sc)
        self.rng, self.state = sc.rng("imu"), ImuErrorState()

    def until_flown(self):
        """(t_s, dtheta_b_rad, dvel_b_mps) of the samples newly flown (stamps <= ``flight.flown_s``)."""
        f, t, h = self.flight, self.t_s, self.flight.step_s
        parts = []
        while self.k < len(t) and t[self.k] <= f.flown_s + _EPS:
            end = min(math.ceil(t[self.k] / h - _EPS) * h, f.flown_s)     # the end of this sample's step
            k1 = int(np.searchsorted(t, end + _EPS, side="right"))
            dth, dv = f.imu_increments(t[self.k:k1], self.dt_s)
            dth, dv = corrupt_increments(dth, dv, self.dt_s, self.errors, self.rng, self.state)
            parts.append((t[self.k:k1], dth, dv))
            self.k = k1
        if not parts:
            return np.empty(0), np.empty((0, 3)), np.empty((0, 3))
        return tuple(np.concatenate(x) for x in zip(*parts))


class FlownFixes(_FlownEpochs):
    """Loosely coupled GNSS fixes of a commanded flight, one epoch at a time (module doc)."""

    def __init__(self, sc, flight, outages=()):
        if "raw" in sc.data["gnss"]:
            raise _not_supported("gnss.raw (the raw-GNSS receiver)")
        self.sc = sc
        self._follow(flight, imu_epochs(sc["duration_s"], sc["gnss.rate_hz"]))
        self.outages = tuple(parse_outages(sc.data["gnss"].get("outages_s"))) + tuple(outages)
        self.rng = sc.rng("gnss")

    def until(self, t_s: float) -> list:
        """The fixes stamped <= min(t_s, flown_s), each a one-epoch ``GnssFixes`` (none inside an outage)."""
        sc, out = self.sc, []
        for j in self._due(min(t_s, self.flight.flown_s)):
            g = simulate_fixes(self.flight, self.t_s[j:j + 1], sc["gnss.pos_sigma_enu_m"],
                               sc["gnss.vel_sigma_enu_mps"], sc["gnss.antenna_lever_arm_b_m"], self.rng)
            if not any(a <= self.t_s[j] < b for a, b in self.outages):       # drawn in an outage too (same noise)
                out.append(g)
        return out


class FlownRaw(_FlownEpochs):
    """Raw-GNSS receiver epochs of a commanded flight, one epoch at a time (module doc)."""

    def __init__(self, sc, flight, outages=()):
        import copy

        from .gnss.receiver import ANTENNA_DIFF_S
        from .simulate import gnss_receiver
        from .scenario import Scenario
        if "raw" not in sc.data["gnss"]:
            raise ValueError("FlownRaw: the scenario has no gnss.raw block (FlownFixes draws white-noise fixes)")
        if outages:                              # the receiver's own blackout: lock lost in the windows
            data = copy.deepcopy(sc.data)
            lock = data["gnss"]["raw"].setdefault("lock", {})
            lock["outages"] = list(lock.get("outages") or []) + [[float(a), float(min(b, 1e9))] for a, b in outages]
            sc = Scenario(sc.path, data)
        self.lead_s = ANTENNA_DIFF_S
        self._follow(flight, imu_epochs(sc["duration_s"], sc["gnss.rate_hz"]))
        self.run = gnss_receiver(sc).run(flight, self.t_s, sc.rng("gnss_raw"), lazy=True)

    def until(self, t_s: float) -> list:
        """The receiver epochs (``GnssEpoch``) stamped <= t_s whose antenna truth is flown."""
        return [self.run.epoch(k) for k in self._due(min(t_s, self.flight.flown_s - self.lead_s))]


class FlownMag(_FlownEpochs):
    """Magnetometer samples of a commanded flight, one epoch at a time (module doc)."""

    def __init__(self, sc, flight):
        self.errors = MagnetometerErrors.from_config(sc.data["magnetometer"])
        if self.errors.map_error_model == "white_uniform" and self.errors.map_error_rms_nT > 0.0:
            raise _not_supported("magnetometer.map_error_model white_uniform")
        self.sc = sc
        self._follow(flight, imu_epochs(sc["duration_s"], sc["magnetometer.rate_hz"]))
        self.rng = sc.rng("mag")

    def until_flown(self):
        """(t_s, field_b_T) of the epochs newly flown."""
        sc, t, rows = self.sc, [], []
        for j in self._due(self.flight.flown_s):
            rows.append(simulate_magnetometer_T(self.flight, self.t_s[j:j + 1], sc["magnetometer.epoch_decimal_year"],
                                                sc["magnetometer.noise_nT"], self.rng, errors=self.errors)[0])
            t.append(self.t_s[j])
        return np.asarray(t, float), np.asarray(rows, float).reshape(-1, 3)
