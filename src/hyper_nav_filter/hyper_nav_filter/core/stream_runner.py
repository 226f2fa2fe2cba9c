"""The fusion engine stepped over streams without ROS: the one loop of the
offline flights, reproductions, studies and Monte Carlo runs (the live node
and ``replay_filter`` take their inputs as messages instead:
``hyper_nav_filter.offline_arrays``).

Per IMU sample, in the order the fusion node receives its inputs:

1. each feed's inputs delivered before the sample (``before(eng, t)``: a
   receiver's latency puts a fix behind later IMU samples);
2. the sample (``FusionEngine.add_imu``);
3. each feed's inputs stamped at or before it (``until(eng, t)``);
4. every ``release_every`` samples, the released solutions, handed to each
   feed that takes them (``released(eng, solutions)``: aiding nodes take
   them as their ``nav/state``), then kept (all, or those ``keep`` accepts).

After the last sample, the final release (step 4 with ``final=True``). A
feed is any object with any of ``before``, ``until``, ``released``;
``Stamped`` makes one of a time-ordered list of measurements, and
``hyper_nav_workbench.core.mc_sources.Feed`` is the scenario's declared
sources. No rclpy.
"""
from __future__ import annotations

import time


class Stamped:
    """A time-ordered list of measurements as a feed: each added after the
    IMU sample its stamp reaches (``delivery_delay_s`` None), or, with a
    receiver's latency, before the first IMU sample later than its stamp +
    ``delivery_delay_s``. ``on_add(eng, m)`` replaces ``eng.add_measurement(m)``."""

    def __init__(self, measurements, delivery_delay_s: float | None = None, on_add=None):
        self.items = measurements
        self.j = 0
        self.delay_s = delivery_delay_s
        self.on_add = on_add
        if delivery_delay_s is None:
            self.until = self._until
        else:
            self.before = self._before

    def _add(self, eng, m) -> None:
        if self.on_add is None:
            eng.add_measurement(m)
        else:
            self.on_add(eng, m)

    def _until(self, eng, t_s: float) -> None:
        items = self.items
        while self.j < len(items) and items[self.j].t_s <= t_s + 1e-9:
            self._add(eng, items[self.j])
            self.j += 1

    def _before(self, eng, t_s: float) -> None:
        items, d = self.items, self.delay_s
        while self.j < len(items) and items[self.j].t_s + d <= t_s - 1e-9:
            self._add(eng, items[self.j])
            self.j += 1


class StreamRunner:
    """The engine ``eng`` over IMU samples and ``feeds`` (module doc).
    ``release_every``: samples between releases (a release only hands over
    what the engine's horizon has passed, so the cadence changes no
    number); ``keep(solution)``: which released solutions ``solutions``
    keeps (default all)."""

    def __init__(self, eng, feeds=(), release_every: int = 1, keep=None):
        self.eng = eng
        self.feeds = list(feeds)
        self.release_every = int(release_every)
        if self.release_every < 1:
            raise ValueError(f"release_every: at least 1, got {release_every}")
        self.keep = keep
        self.solutions: list = []
        self.samples = 0
        self._before = [f.before for f in self.feeds if hasattr(f, "before")]
        self._until = [f.until for f in self.feeds if hasattr(f, "until")]
        self._released = [f.released for f in self.feeds if hasattr(f, "released")]
        self._wall = None

    def step(self, t_s, dtheta_b_rad, dvel_b_mps, rates: bool = False) -> list:
        """One IMU sample (steps 1-4); returns what it released ([] between releases).
        ``rates``: the sample is given as mean rates over its interval
        (``FusionEngine.add_imu_rates``, as a sensor_msgs/Imu carries it)."""
        eng = self.eng
        add = eng.add_imu_rates if rates else eng.add_imu
        for f in self._before:
            f(eng, t_s)
        if self._wall is None:
            add(t_s, dtheta_b_rad, dvel_b_mps)
        else:
            t0 = time.perf_counter()
            add(t_s, dtheta_b_rad, dvel_b_mps)
            self._wall[self.samples] = time.perf_counter() - t0
        for f in self._until:
            f(eng, t_s)
        self.samples += 1
        if self.samples % self.release_every:
            return []
        return self._take(eng.release())

    def finish(self) -> list:
        """The final release (everything the engine holds); returns it."""
        return self._take(self.eng.release(final=True))

    def _take(self, sols: list) -> list:
        for f in self._released:
            f(self.eng, sols)
        if self.keep is None:
            self.solutions += sols
        else:
            self.solutions += [s for s in sols if self.keep(s)]
        return sols

    def run(self, t_s, dtheta_b_rad, dvel_b_mps, n: int | None = None, on_sample=None,
            imu_wall_s=None) -> list:
        """Samples 0..n-1 of the arrays (all by default), then the final
        release; returns the kept solutions. ``on_sample(k, t_s)`` after each
        sample's step; ``imu_wall_s`` (an array of n, for a runner that has taken no
        sample yet) receives each ``add_imu``'s wall time (latency studies)."""
        n = len(t_s) if n is None else int(n)
        self._wall = imu_wall_s
        try:
            for k in range(n):
                self.step(t_s[k], dtheta_b_rad[k], dvel_b_mps[k])
                if on_sample is not None:
                    on_sample(k, t_s[k])
        finally:
            self._wall = None
        self.finish()
        return self.solutions
