"""The boost-glide flight stepped with live bank and lift commands (issue 36).

``CommandedFlight`` flies the equations of motion of
:class:`~.boost_glide.DynamicTrajectory` (the same ``_rhs``, actuator lag and
rate limits: dsigma/dt = r_sigma tanh((sigma_cmd - sigma)/(tau_sigma r_sigma)),
dc_l/dt likewise) step by step, while commands arrive, instead of
integrating a command program to the end before the flight starts. The
scenario's program (``flight.maneuvers`` and the altitude guidance) flies
every step that no command is in force for; a command replaces the
program's (sigma_cmd, c_l_cmd) from its step on, until the next one.

Determinism (live == offline, bit for bit)
------------------------------------------
* Time is cut on a fixed grid of ``step_s`` (the command step), each step
  split further only at the programs' break points: how often ``advance``
  is called, and up to where, never changes a float of the flight.
* A command carries the navigation stamp t_nav it was computed from. It
  applies at the declared step

      k_apply = ceil((t_nav + apply_delay_s) / step_s)

  (from t = k_apply step_s on, held until the next command's step), never
  at its arrival time. Of several commands for the same step the one with
  the newest t_nav wins (ties: the later-given one), so arrival order does
  not matter either.
* A command whose step was flown already (it came later than its apply
  step) is refused ("late") and counted: a live loop whose guidance is
  slower than ``apply_delay_s`` in *flight* time is a configuration error,
  not a silent difference. The truth node prevents it by holding the clock
  (``pending_steps``).

Limits: |sigma_cmd| <= ``bank_max_rad``, c_l_min <= c_l_cmd <= c_l_max of
the vehicle, finite; anything else is refused with its reason, counted in
``refused`` by reason, and changes nothing.
"""
from __future__ import annotations

import math
from collections import Counter

import numpy as np
from scipy.integrate import solve_ivp

from .boost_glide import DynamicTrajectory, _Segment
from .boost_glide_config import parse_flight

_ATOL = np.array([1e-13, 1e-13, 1e-6, 1e-8, 1e-8, 1e-8, 1e-8, 1e-12, 1e-12])


class CommandedFlight(DynamicTrajectory):
    """A ``DynamicTrajectory`` integrated step by step as commands arrive.

    ``command(t_nav_s, sigma_cmd_rad, c_l_cmd)`` queues a command; ``advance(t_s)``
    integrates every whole step that ends at or before t_s; ``truth(t)``,
    ``flight(t)``, ``state(t)`` and ``imu_increments`` work for t up to
    ``flown_s``. ``commands`` lists the commands applied (t_apply_s, t_nav_s,
    sigma_cmd_rad, c_l_cmd)."""

    def __init__(self, *args, step_s: float = 0.1, apply_delay_s: float = 0.1,
                 bank_max_rad: float = math.pi, **kw):
        if not step_s > 0.0:
            raise ValueError(f"step_s: must be > 0, got {step_s!r}")
        if not apply_delay_s >= 0.0:
            raise ValueError(f"apply_delay_s: must be >= 0, got {apply_delay_s!r}")
        self.step_s = float(step_s)
        self.apply_delay_s = float(apply_delay_s)
        self.bank_max_rad = float(bank_max_rad)
        self._pending: dict[int, tuple] = {}
        self.commands: list[tuple[float, float, float, float]] = []
        self.refused: Counter = Counter()
        self.accepted = 0
        self._cmd_t = np.empty(0)
        self._cmd_v = np.empty((0, 2))
        super().__init__(*args, **kw)

    @classmethod
    def from_config(cls, d: dict, **kw) -> "CommandedFlight":
        return cls(**parse_flight(d), **kw)

    # ---- commands ---------------------------------------------------------------
    def apply_step(self, t_nav_s: float) -> int:
        """The step a command computed from navigation stamp t_nav_s applies at."""
        return int(math.ceil((t_nav_s + self.apply_delay_s) / self.step_s - 1e-9))

    def check(self, sigma_cmd_rad: float, c_l_cmd: float) -> str | None:
        """None when the command is within limits, else the reason it is refused."""
        veh = self.vehicle
        if not (math.isfinite(sigma_cmd_rad) and math.isfinite(c_l_cmd)):
            return "not_finite"
        if abs(sigma_cmd_rad) > self.bank_max_rad + 1e-12:
            return "bank_out_of_range"
        if not veh.c_l_min <= c_l_cmd <= veh.c_l_max:
            return "c_l_out_of_range"
        return None

    def command(self, t_nav_s: float, sigma_cmd_rad: float, c_l_cmd: float) -> str | None:
        """Queue a command computed from the navigation state at t_nav_s.
        Returns None when accepted, else the reason it was refused (counted)."""
        why = self.check(float(sigma_cmd_rad), float(c_l_cmd))
        if why is None and not math.isfinite(t_nav_s):
            why = "not_finite"
        k = self.apply_step(t_nav_s) if why is None else 0
        if why is None and k < self._k:
            why = "late"
        if why is not None:
            self.refused[why] += 1
            return why
        old = self._pending.get(k)
        if old is None or t_nav_s >= old[0]:
            self._pending[k] = (float(t_nav_s), float(sigma_cmd_rad), float(c_l_cmd))
        self.accepted += 1
        return None

    @property
    def flown_s(self) -> float:
        """Time up to which the flight is integrated."""
        return self._k * self.step_s if not self.terminated_early else self.duration_s

    @property
    def finished(self) -> bool:
        """The flight is integrated to its end (its duration or an end event)."""
        return self.terminated_early or self._k * self.step_s >= self._t_max - 1e-9

    @property
    def next_step(self) -> int:
        """Index of the next step to integrate (its commands must be in by then)."""
        return self._k

    # ---- integration ----------------------------------------------------------------
    def _integrate(self, t_max, rtol):
        """Called by the base constructor: set the flight up, integrate nothing."""
        self._y = self._y0 = self._initial_state()
        self._rtol = rtol
        self._t_max = t_max
        self._k = 0
        self._segments = []
        self._bounds = np.empty(0)
        self.terminated_early = False
        self.duration_s = t_max
        self._bp = self.break_points(t_max + 1.0)
        self._events = []
        if self.end_speed_mps is not None:
            ev = lambda t, y: math.sqrt(y[3]**2 + y[4]**2 + y[5]**2) - self.end_speed_mps  # noqa: E731
            ev.terminal, ev.direction = True, -1
            self._events.append(ev)
        if self.end_alt_m is not None:
            ea = lambda t, y: y[2] - self.end_alt_m  # noqa: E731
            ea.terminal, ea.direction = True, -1
            self._events.append(ea)

    def advance(self, t_s: float) -> float:
        """Integrate every whole step ending at or before t_s (and the flight's
        end); returns ``flown_s``."""
        h = self.step_s
        n_max = int(math.ceil(self._t_max / h - 1e-9))
        while not self.terminated_early and self._k < n_max and (self._k + 1) * h <= t_s + 1e-9:
            self._step()
        return self.flown_s

    def _step(self):
        k, h = self._k, self.step_s
        cmd = self._pending.pop(k, None)
        if cmd is not None:
            self._active_command = (cmd[1], cmd[2])
            self.commands.append((k * h, *cmd))
            self._cmd_t = np.append(self._cmd_t, k * h)
            self._cmd_v = np.vstack([self._cmd_v, [cmd[1], cmd[2]]])
        t0, t1 = k * h, min((k + 1) * h, self._t_max)
        inner = self._bp[(self._bp > t0 + 1e-12) & (self._bp < t1 - 1e-12)]
        for a, b in zip([t0, *inner], [*inner, t1]):
            sol = solve_ivp(self._rhs, (a, b), self._y, method="DOP853", rtol=self._rtol, atol=_ATOL,
                            dense_output=True, events=self._events or None, max_step=10.0)
            if not sol.success:
                raise RuntimeError(f"flight integration failed at t = {a} s: {sol.message}")
            self._segments.append(_Segment(a, float(sol.t[-1]), sol.sol))
            self._y = sol.y[:, -1]
            if sol.status == 1:
                self.terminated_early = True
                self.duration_s = float(sol.t[-1])
                break
        self._bounds = np.array([s.t0 for s in self._segments[1:]])
        self._k += 1

    def run(self, duration_s: float | None = None) -> "CommandedFlight":
        """Integrate to the end (offline: commands given beforehand)."""
        self.advance(self._t_max if duration_s is None else duration_s)
        return self

    # ---- evaluation -----------------------------------------------------------------
    def _commands_at(self, t):
        if len(self._cmd_t) == 0:
            return None
        idx = np.searchsorted(self._cmd_t, t, side="right") - 1
        on = idx >= 0
        j = np.maximum(idx, 0)
        return on, self._cmd_v[j, 0], self._cmd_v[j, 1]

    def state(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if len(t) and t.max() > self.flown_s + 1e-9:
            raise ValueError(f"truth asked at t = {t.max():.3f} s, the flight is integrated to "
                             f"{self.flown_s:.3f} s")
        if not self._segments:                   # nothing flown yet: the initial state (t = 0)
            return np.repeat(self._y0[:, None], len(t), axis=1)
        return super().state(t)


def flight_of_scenario(sc) -> tuple:
    """(GuidanceConfig, CommandedFlight) of a scenario with ``guidance:`` and
    ``flight:`` blocks: the one construction the truth node, the sensor
    nodes' mirrors (``nodes.flight_mirror``) and the offline loops share, so
    that they fly the same flight bit for bit."""
    from .guidance_config import GuidanceConfig
    cfg = GuidanceConfig.from_config(sc.data["guidance"])
    fl = dict(sc.data["flight"])
    fl.setdefault("duration_s", sc["duration_s"])
    return cfg, CommandedFlight(**parse_flight(fl), step_s=cfg.period_s, apply_delay_s=cfg.apply_delay_s,
                                bank_max_rad=cfg.bank_limit_rad)


def is_commanded(sc) -> bool:
    """Whether the scenario's flight is flown live on commands (a ``guidance:`` and a ``flight:`` block)."""
    return "guidance" in sc.data and "flight" in sc.data


class CommandLoop:
    """The flight's side of a live loop (truth node, offline loops): which
    steps may be flown given the commands received.

    A guidance that is in the loop (``expect``) sends one command per
    navigation stamp on its grid t_j = j period_s (t_j >= t_start_s, before
    the flight's end), and command j applies at step j + m,
    m = ceil(apply_delay_s / period_s); none is awaited for a stamp after
    ``t_end_s`` (the end of the navigation data: the scenario's duration_s).
    So step k may be integrated once
    every command j <= k - m has arrived (accepted or refused: a refused
    one is counted and the previous command holds) or been given up
    (``give_up``: counted as missed). The flight then never depends on when
    a command arrived, only on its stamp and values."""

    def __init__(self, flight: CommandedFlight, t_start_s: float = 0.0, expect: bool = True,
                 t_end_s: float = math.inf):
        self.flight = flight
        self.expect = bool(expect)
        self.t_end_s = float(t_end_s)
        P = flight.step_s
        self.j_first = int(math.ceil(t_start_s / P - 1e-9))
        self.m = flight.apply_step(0.0)
        self._arrived: set[int] = set()
        self.next_j = self.j_first           # the oldest command not arrived yet
        self.missed = 0
        self.off_grid = 0

    def receive(self, t_nav_s: float, sigma_cmd_rad: float, c_l_cmd: float) -> str | None:
        """A command from the stream: None if accepted, else the reason it was refused."""
        P = self.flight.step_s
        j = int(round(t_nav_s / P))
        if abs(t_nav_s - j * P) > 1e-6:
            self.off_grid += 1                   # not on the guidance grid: applies, but nothing waits for it
        else:
            self._arrived.add(j)
            while self.next_j in self._arrived:
                self._arrived.discard(self.next_j)
                self.next_j += 1
        return self.flight.command(t_nav_s, sigma_cmd_rad, c_l_cmd)

    def flyable_s(self) -> float:
        """The time up to which the flight may be integrated now."""
        f = self.flight
        if not self.expect or f.finished or self.next_j * f.step_s > self.t_end_s + 1e-9:
            return math.inf                      # no navigation after t_end_s: no command to wait for
        return (self.next_j + self.m) * f.step_s

    def waiting_for_s(self) -> float | None:
        """The navigation stamp of the command the flight waits for, or None."""
        f = self.flight
        if not self.expect or f.finished or f.flown_s + 1e-9 < self.flyable_s():
            return None
        return self.next_j * f.step_s

    def give_up(self) -> None:
        """Fly on without the awaited command (it is counted as missed)."""
        self.missed += 1
        self.next_j += 1
        while self.next_j in self._arrived:
            self._arrived.discard(self.next_j)
            self.next_j += 1

    def advance(self, t_s: float) -> float:
        """Integrate up to min(t_s, flyable_s()); returns ``flown_s``."""
        return self.flight.advance(min(t_s, self.flyable_s()))
