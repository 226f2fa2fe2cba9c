"""The geomagnetic aiding engine: the node's whole logic without ROS.

``GeomagAiding.process(sample, nav)`` takes one magnetometer epoch (the
measured total intensity) and the navigation solution at that epoch and
returns a ``MatchResult`` (a fix, or the reason there is none) or None (the
matcher has nothing this epoch, or matching has not started). The live node
(``nodes/geomag_node.py``) and the offline reproduction
(``repro_seed003``) call exactly this.

Bad input never raises: non-finite samples, a missing or mismatched map, a
solution outside the map, or a measured field that cannot be this map's
(``mismatch_sigma`` test below) give no fix and are counted in
``counters`` (the node puts them on /diagnostics):

* ``rejected_mag_nan``, ``rejected_nav_nan``
* ``no_map`` (the map file was refused; ``map_problem`` says why)
* ``off_map`` (the solution or the matching area leaves the map)
* ``rejected_field_mismatch``: |F_map(r^) - m| beyond 10 sigma of what the
  map error, the sensor noise and the navigation covariance allow (a map of
  another epoch or place, a magnetometer fault)
* ``rejected_map_epoch``: with an epoch check (``core.map_epoch``), the
  secular change the map misses at the solution and the sample's stamp is
  beyond ``map_epoch_tolerance_nT`` (the check at start passed: a stamp far
  from stamp 0); within it, every result carries it (``map_epoch_bias_nT``)
* ``no_fix_<code>`` (the matcher declined, e.g. ``no_fix_contour_off_area``:
  an ICCP contour point outside its matching area or the map)
* ``fixes``.
"""
from __future__ import annotations

import time
from collections import Counter

import numpy as np

from hyper_nav_aiding.geomag.core.ekf_intensity import EkfIntensity
from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig
from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap, MapError, OffMapError, get_or_build, load_map
from hyper_nav_aiding.geomag.core.iccp import Iccp
from hyper_nav_aiding.geomag.core.magcom import Magcom
from hyper_nav_aiding.geomag.core.map_epoch import EpochOffset, bring_forward
from hyper_nav_aiding.geomag.core.matching import MagSample, MatchResult, NavPoint
from hyper_nav_aiding.geomag.core.siman import Siman

MISMATCH_SIGMA = 10.0
COUNTED_CODES = ("no_map", "off_map", "rejected_field_mismatch", "rejected_map_epoch")


def make_matcher(cfg: GeomagConfig, gmap: GeomagMap):
    """The configured algorithm (``cfg.algorithm``) on the map."""
    sigma = float(np.hypot(cfg.field_sigma_nT, cfg.sensor_sigma_nT))
    across = cfg.ekf.across_sigma_m
    builders = {
        "MAGCOM": lambda: Magcom(gmap, cfg.magcom, sigma, cfg.fix_covariance, cfg.isotropic_sigma_m, across),
        "ICCP": lambda: Iccp(gmap, cfg.iccp, sigma, cfg.fix_covariance, cfg.isotropic_sigma_m, across),
        "SIMAN": lambda: Siman(gmap, cfg.siman, sigma),
        "EKF": lambda: EkfIntensity(gmap, cfg.ekf, cfg.field_sigma_nT, cfg.sensor_sigma_nT),
    }
    return builders[cfg.algorithm]()


def load_configured_map(cfg: GeomagConfig, build_if_missing: bool = True, log=None) -> GeomagMap:
    """``cfg.map_file`` when given (checked against ``cfg.map``), else the
    cache entry for ``cfg.map`` (built on first use when allowed)."""
    if cfg.map_file:
        return load_map(cfg.map_file, cfg.map)
    if not build_if_missing:
        from hyper_nav_aiding.geomag.core.geomag_map import cached_map_path
        return load_map(cached_map_path(cfg.map, cfg.map_cache_dir or None), cfg.map)
    return get_or_build(cfg.map, cfg.map_cache_dir or None, log=log)


class GeomagAiding:
    def __init__(self, cfg: GeomagConfig, gmap: GeomagMap | None, map_problem: str = "",
                 epoch: EpochOffset | None = None):
        """``epoch``: the map's epoch checked against the flight's date
        (``map_epoch.check``; the map already brought forward when it says
        so); None = no epoch check (unit tests of the matchers)."""
        self.cfg = cfg
        self.map = gmap
        self.map_problem = map_problem if gmap is None else ""
        self.epoch = epoch
        self.last_epoch_bias_nT = float("nan")
        self.matcher = make_matcher(cfg, gmap) if gmap is not None else None
        self.counters: Counter = Counter()
        self.compute_time_s = 0.0          # wall
        self.compute_cpu_s = 0.0           # CPU time of the calling thread (robust on a loaded machine)
        self.last: MatchResult | None = None

    @classmethod
    def from_config(cls, cfg: GeomagConfig, build_if_missing: bool = True, log=None,
                    epoch: EpochOffset | None = None) -> "GeomagAiding":
        """Load the map (brought to the flight's date when ``epoch`` says
        so); a refused map leaves the engine running without fixes
        (``map_problem`` holds the error message)."""
        try:
            gmap = load_configured_map(cfg, build_if_missing, log)
            if epoch is not None and epoch.brought_forward:
                gmap = bring_forward(gmap, epoch.measurement_epoch_decimal_year)
            return cls(cfg, gmap, epoch=epoch)
        except MapError as exc:
            return cls(cfg, None, str(exc), epoch=epoch)

    def epoch_report(self) -> dict:
        """The map-epoch figures for /diagnostics and table3.json: at start
        over the map (``EpochOffset.summary``), and the last along the track."""
        if self.epoch is None:
            return {}
        return {**self.epoch.summary(), "map_epoch_tolerance_nT": self.cfg.map_epoch_tolerance_nT,
                "map_epoch_bias_track_nT": round(self.last_epoch_bias_nT, 4)}

    def process(self, sample: MagSample, nav: NavPoint) -> MatchResult | None:
        t0, c0 = time.perf_counter(), time.thread_time()
        res = self._process(sample, nav)
        dt = time.perf_counter() - t0
        self.compute_time_s += dt
        self.compute_cpu_s += time.thread_time() - c0
        if res is not None:
            res.compute_time_s = dt
            res.map_epoch_bias_nT = self.last_epoch_bias_nT
            if res.valid:
                self.counters["fixes"] += 1
            elif res.code not in COUNTED_CODES:                  # those are counted where they arise
                self.counters[f"no_fix_{res.code or 'other'}"] += 1
            self.last = res
        return res

    def _invalid(self, t_s: float, reason: str, counter: str) -> MatchResult:
        self.counters[counter] += 1
        return MatchResult(t_s, self.cfg.algorithm, False, reason, code=counter)

    def _process(self, sample: MagSample, nav: NavPoint) -> MatchResult | None:
        self.counters["mag_samples"] += 1
        if sample.t_s < self.cfg.start_s - 1e-9:
            self.counters["before_start"] += 1
            return None
        if not (np.isfinite(sample.t_s) and np.isfinite(sample.total_nT)) or sample.total_nT <= 0:
            self.counters["rejected_mag_nan"] += 1
            return None
        if not all(np.all(np.isfinite(v)) for v in (nav.lat_rad, nav.lon_rad, nav.alt_m, nav.vel_enu_mps)):
            self.counters["rejected_nav_nan"] += 1
            return None
        if self.epoch is not None:                       # this sample's, also on a result without a map
            self.last_epoch_bias_nT = self.epoch.bias_nT(nav.lat_rad, nav.lon_rad, sample.t_s)
        if self.map is None:
            return self._invalid(sample.t_s, f"no map: {self.map_problem}", "no_map")
        if self.epoch is not None:
            b = self.last_epoch_bias_nT
            if abs(b) > self.cfg.map_epoch_tolerance_nT:
                self.matcher.reset()
                return self._invalid(sample.t_s, f"map epoch: {b:+.3g} nT of secular change at t = "
                                     f"{sample.t_s:.1f} s, beyond geomag.map_epoch_tolerance_nT = "
                                     f"{self.cfg.map_epoch_tolerance_nT:g} nT", "rejected_map_epoch")
        try:
            f, g = self.map.total_and_gradient(nav.lat_rad, nav.lon_rad, nav.alt_m)
        except OffMapError as exc:
            self.matcher.reset()
            return self._invalid(sample.t_s, f"off map: {exc}", "off_map")
        if not self._plausible(sample.total_nT - float(f), g, nav):
            self.matcher.reset()
            return self._invalid(sample.t_s, "field mismatch", "rejected_field_mismatch")
        try:
            return self.matcher.step(sample, nav)
        except OffMapError as exc:
            self.matcher.reset()
            return self._invalid(sample.t_s, f"off map: {exc}", "off_map")

    def _plausible(self, dz_nT: float, g: np.ndarray, nav: NavPoint) -> bool:
        """Could a measured-minus-map difference dz come from this map, given
        the map error, sensor noise and the solution's uncertainty?"""
        P = np.asarray(nav.cov_en_m2, float)
        lam = float(np.linalg.eigvalsh(P)[-1]) if np.all(np.isfinite(P)) else 1e8
        alt_var = nav.alt_var_m2 if np.isfinite(nav.alt_var_m2) else 1e4
        var = (self.cfg.field_sigma_nT**2 + self.cfg.sensor_sigma_nT**2 + float(g[0]**2 + g[1]**2) * lam
               + float(g[2]**2) * alt_var)
        return abs(dz_nT) <= MISMATCH_SIGMA * np.sqrt(var)
