"""Map epoch against the epoch of the measurement (issue 27): the secular
change a geomagnetic map does not hold is checked against a stated
tolerance, reported, or brought forward; never used silently.

**Model.** Over a release's five-year life span the World Magnetic Model's
Gauss coefficients are linear in time (WMM2025 technical report, Chulliat
et al., NOAA NCEI / BGS, the model equations):

    g_n^m(t) = g_n^m(t0) + (t - t0) gdot_n^m,   h_n^m likewise,

so the field components are linear in time as well:

    B(x, t) = B(x, t_m) + (t - t_m) Bdot(x),                             (1)

where ``Bdot`` is the same spherical-harmonic synthesis with the
secular-variation coefficients (gdot, hdot) in place of (g, h)
(``secular_variation_enu_nT_per_yr``: pygeomag run on the release's SV
coefficients; equal to pygeomag's B(t + 1) - B(t) to 1e-9 nT, checked by a
test). The total intensity the matchers compare, F = |B|, is not linear
in t.

**The bias.** A map holds the field at its epoch t_m
(``geomag.map.epoch_decimal_year``); the magnetometer measures it at the
flight's date t_f (``magnetometer.epoch_decimal_year``, the date at stamp
0; a sample stamped t_s seconds later is at t_f + t_s / 31 557 600 s,
Julian years). A matcher takes their difference for position, through the
field gradient (3-4.5 nT/km at seed 003's map). At a point x of the map::

    b(x) = F_rel(t_f)(x, t_f) - F_map(x)                                 (2)

    F_map = F_rel(t_m)(x, t_m)                         (map used as built)
          = |B_rel(t_m)(x, t_m) + (t_f - t_m) Bdot_rel(t_m)(x)|  (brought forward, (1))

rel(t) is the WMM release valid at t (``hyper_nav_filter.core.wmm.release_for``,
the simulated magnetometer's model), so b is the measured-minus-map bias
the simulation produces beside its map error (the simulated magnetometer
holds t_f over the whole flight: the stamp term, 8e-4 nT over seed 003's
790 s at +33 nT/yr, is ours); across a release boundary a brought-forward
map's b is the old release's forecast against the new one.

``map_epoch_offset`` evaluates (2) on a coarse grid over the map region at
the map altitude: 1 deg steps, at least 4 nodes a side. The secular
variation of a degree-12 model has no structure shorter than ~3000 km: a
bicubic spline through 1 deg nodes gives Bdot within 5e-5 nT/yr of
pygeomag at every 0.1 deg node of 33.5-25.5 S 140.5-143.5 E (0.5 deg
nodes: 3e-6 nT/yr; measured), and the check takes 36 nodes for seed 003's
8 x 3 deg map (0.05 s, measured on the loaded 2-core machine).

**Tolerance (choice and reason).** On b in nT, not on |t_f - t_m| in
years: the secular variation of F differs by more than a factor of ten over
the globe (-11.6 nT/yr at 33 S 143 E and +33 nT/yr at 44 N 110 E, 32 km,
WMM-2025), so a tolerance in years means nothing without the place, while
b is what the matcher sees, beside its map error. ``geomag.map_epoch_tolerance_nT``
(default 0.1 nT, seed 003's smallest map-error level: a bias at the limit
stays inside the map error at every level the paper flies, and moves a fix
by 0.1 nT / (3-4.5 nT/km) = 22-33 m along the gradient). Beyond it the map
is refused (``MapEpochError``: both fields, the years between them and the
implied nT); within it b is reported (mean and range over the map at start,
and along the track per sample). For scale, WMM2025's own uncertainty for F
is 138 nT (1 sigma, global; the technical report's error model, as
pygeomag's ``calculate_uncertainty``), dominated by the crustal field it
omits: the simulation's map error (0.1-10 nT) stands for a survey map's,
and only the core field's change (1) is what a map of another epoch misses.

**Bringing a map forward** (``geomag.map_bring_forward``; ``bring_forward``):
(1) applied to the map's component layers with Bdot (and its height
derivative) splined from the same coarse grid, then F and dF/dh recomputed
from the components exactly as ``geomag_map.build_layers`` computes them.
Within one release it equals a map built at the target date to 1e-4 nT
for 1.5 years (F: 5e-5 nT at 33.5-25.5 S 140.5-143.5 E, 9e-5 nT at 40-48 N
109-112 E; dF/dh 2e-10 nT/m; measured, and tested to 1e-3 nT); it costs the
coarse grid and rebuilding the map's splines: 0.1-0.16 s for a 161 x 61
grid (whose build takes 8-20 s), 0.8-2.1 s for seed 003's 801 x 301 grid
(build: about 45 s), measured under load.
"""
from __future__ import annotations

import dataclasses
import functools
import importlib
import math
import pathlib
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RectBivariateSpline

from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap, MapError, MapSpec

SECONDS_PER_YEAR = 365.25 * 86400.0     # Julian year: stamps (s) to decimal years
COARSE_STEP_DEG = 1.0                   # grid of the check and of Bdot (see the module docstring)
MIN_NODES = 4                           # bicubic splines need 4 nodes a side
MAP_EPOCH_FIELD = "geomag.map.epoch_decimal_year"
MEASUREMENT_EPOCH_FIELD = "magnetometer.epoch_decimal_year"
TOLERANCE_FIELD = "geomag.map_epoch_tolerance_nT"


class MapEpochError(MapError):
    """The map's epoch is too far from the measurement's: the message names
    both fields and the implied secular change in nT."""


# ---- the model: main field and secular variation of the release valid at a date --------------
def _release(decimal_year: float, field: str):
    from hyper_nav_filter.core.wmm import release_for
    return release_for(decimal_year, field)


@functools.lru_cache(maxsize=None)
def _models(coefficients_file: str):
    """(main field, secular variation) pygeomag models of one release. The
    main field reads the coefficient file (as the map and the simulated
    magnetometer do); the secular-variation model is pygeomag on the same
    release's (gdot, hdot) in place of (g, h) (``pygeomag.wmm.<release>``
    data), whose synthesis is Bdot in eq. (1)."""
    from pygeomag import GeoMag
    name = pathlib.PurePosixPath(coefficients_file).stem              # WMM_2025
    (epoch, model, date), coeffs = getattr(importlib.import_module(f"pygeomag.wmm.{name.lower()}"), name)
    sv = [(n, m, dg, dh, 0.0, 0.0) for n, m, _g, _h, dg, dh in coeffs]
    return GeoMag(coefficients_file=coefficients_file), GeoMag(coefficients_data=((epoch, f"{model} SV", date), sv))


def _enu(r) -> tuple:
    return (r.y, r.x, -r.z)                 # pygeomag X north, Y east, Z down -> E, N, U


def _wrap_lon(lon_deg: float) -> float:
    return (float(lon_deg) + 180.0) % 360.0 - 180.0


def field_enu_nT(lat_deg: float, lon_deg: float, alt_m: float, decimal_year: float,
                 field: str = MEASUREMENT_EPOCH_FIELD) -> np.ndarray:
    """WMM main field (E, N, U) [nT] of the release valid at ``decimal_year``."""
    main, _ = _models(_release(decimal_year, field).coefficients_file)
    return np.array(_enu(main.calculate(glat=float(lat_deg), glon=_wrap_lon(lon_deg), alt=alt_m / 1000.0,
                                        time=float(decimal_year))))


def secular_variation_enu_nT_per_yr(lat_deg: float, lon_deg: float, alt_m: float, decimal_year: float,
                                    field: str = MAP_EPOCH_FIELD) -> np.ndarray:
    """Bdot (E, N, U) [nT/yr] of eq. (1): the secular variation of the WMM
    release valid at ``decimal_year`` (constant over the release)."""
    rel = _release(decimal_year, field)
    _, sv = _models(rel.coefficients_file)
    return np.array(_enu(sv.calculate(glat=float(lat_deg), glon=_wrap_lon(lon_deg), alt=alt_m / 1000.0,
                                      time=rel.start_year)))


def coarse_axes_deg(spec: MapSpec) -> tuple[np.ndarray, np.ndarray]:
    """The check's grid over the map: COARSE_STEP_DEG or finer, at least MIN_NODES a side."""
    def axis(lo, hi):
        return np.linspace(lo, hi, max(MIN_NODES, int(math.ceil((hi - lo) / COARSE_STEP_DEG - 1e-9)) + 1))
    return axis(spec.lat_min_deg, spec.lat_max_deg), axis(spec.lon_min_deg, spec.lon_max_deg)


def _grid(fn, lat_deg, lon_deg) -> np.ndarray:
    return np.array([[fn(a, b) for b in lon_deg] for a in lat_deg])


# ---- the bias (eq. 2) ------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class EpochOffset:
    """Eq. (2) over the map: b = F at the measurement epoch - F the map holds
    [nT], on the coarse grid at the map altitude, and dF/dt at the
    measurement epoch [nT/yr] for samples stamped later than stamp 0."""
    map_epoch_decimal_year: float
    measurement_epoch_decimal_year: float       # at stamp 0 (the flight's date)
    brought_forward: bool
    map_model: str                              # the map's release (and its secular variation)
    measurement_model: str                      # the magnetometer's release
    alt_m: float
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    bias_grid_nT: np.ndarray                    # (n_lat, n_lon)
    rate_grid_nT_per_yr: np.ndarray             # (n_lat, n_lon)

    @property
    def years(self) -> float:
        return self.measurement_epoch_decimal_year - self.map_epoch_decimal_year

    @property
    def bias_mean_nT(self) -> float:
        return float(np.mean(self.bias_grid_nT))

    @property
    def bias_min_nT(self) -> float:
        return float(np.min(self.bias_grid_nT))

    @property
    def bias_max_nT(self) -> float:
        return float(np.max(self.bias_grid_nT))

    @property
    def bias_worst_nT(self) -> float:
        """The bias of largest magnitude over the map (signed)."""
        return float(self.bias_grid_nT.flat[int(np.argmax(np.abs(self.bias_grid_nT)))])

    @functools.cached_property
    def _splines(self):
        return (RectBivariateSpline(self.lat_deg, self.lon_deg, self.bias_grid_nT),
                RectBivariateSpline(self.lat_deg, self.lon_deg, self.rate_grid_nT_per_yr))

    def bias_nT(self, lat_rad: float, lon_rad: float, t_s: float = 0.0) -> float:
        """b at a position (the nearest point of the map outside it) for a
        sample stamped t_s seconds after stamp 0: b(x) + dF/dt(x) t_s / year."""
        la = min(max(math.degrees(lat_rad), self.lat_deg[0]), self.lat_deg[-1])
        lo = min(max(math.degrees(lon_rad), self.lon_deg[0]), self.lon_deg[-1])
        b, rate = self._splines
        return float(b.ev(la, lo)) + float(rate.ev(la, lo)) * float(t_s) / SECONDS_PER_YEAR

    def summary(self) -> dict:
        """The figures for /diagnostics and the reproduction's table3.json."""
        return {"map_epoch_decimal_year": self.map_epoch_decimal_year,
                "flight_epoch_decimal_year": self.measurement_epoch_decimal_year,
                "map_brought_forward": self.brought_forward,
                "map_epoch_bias_mean_nT": round(self.bias_mean_nT, 4),
                "map_epoch_bias_min_nT": round(self.bias_min_nT, 4),
                "map_epoch_bias_max_nT": round(self.bias_max_nT, 4)}

    def describe(self) -> str:
        """One line naming both fields, the years between them and the implied nT."""
        how = (f"brought forward with {self.map_model}'s secular variation" if self.brought_forward
               else "used as built")
        models = (self.map_model if self.map_model == self.measurement_model
                  else f"{self.map_model} map, {self.measurement_model} at the flight")
        return (f"{MAP_EPOCH_FIELD} = {self.map_epoch_decimal_year:g} and {MEASUREMENT_EPOCH_FIELD} = "
                f"{self.measurement_epoch_decimal_year:g} are {abs(self.years):.3f} years apart: the total field "
                f"at the flight's date differs from the map ({how}) by {self.bias_mean_nT:+.3g} nT (mean over "
                f"the map; {self.bias_min_nT:+.3g} to {self.bias_max_nT:+.3g} nT at {self.alt_m:.0f} m; {models})")


@functools.lru_cache(maxsize=64)
def map_epoch_offset(spec: MapSpec, measurement_epoch_decimal_year: float,
                     brought_forward: bool = False) -> EpochOffset:
    """Eq. (2) on the coarse grid over ``spec``'s region at its altitude.
    ``spec.epoch_decimal_year`` and ``measurement_epoch_decimal_year`` must
    each be inside a WMM release (WmmDateError naming the field)."""
    t_m, t_f = float(spec.epoch_decimal_year), float(measurement_epoch_decimal_year)
    rel_m, rel_f = _release(t_m, MAP_EPOCH_FIELD), _release(t_f, MEASUREMENT_EPOCH_FIELD)
    main_m, sv_m = _models(rel_m.coefficients_file)
    main_f, sv_f = _models(rel_f.coefficients_file)
    lat, lon = coarse_axes_deg(spec)
    alt_km = spec.alt_m / 1000.0

    def node(la, lo):
        lo = _wrap_lon(lo)
        b_f = np.array(_enu(main_f.calculate(glat=la, glon=lo, alt=alt_km, time=t_f)))
        bdot_f = np.array(_enu(sv_f.calculate(glat=la, glon=lo, alt=alt_km, time=rel_f.start_year)))
        b_m = np.array(_enu(main_m.calculate(glat=la, glon=lo, alt=alt_km, time=t_m)))
        if brought_forward:
            bdot_m = bdot_f if rel_m == rel_f else \
                np.array(_enu(sv_m.calculate(glat=la, glon=lo, alt=alt_km, time=rel_m.start_year)))
            b_m = b_m + (t_f - t_m) * bdot_m                        # eq. (1)
        f_f = float(np.linalg.norm(b_f))
        return (f_f - float(np.linalg.norm(b_m)), float(b_f @ bdot_f) / f_f)   # eq. (2), dF/dt = B . Bdot / F

    g = _grid(node, lat, lon)
    return EpochOffset(t_m, t_f, bool(brought_forward), rel_m.name, rel_f.name, float(spec.alt_m), lat, lon,
                       g[..., 0].copy(), g[..., 1].copy())


def check(cfg, measurement_epoch_decimal_year) -> EpochOffset:
    """The map of ``cfg`` (a GeomagConfig: ``map``, ``map_bring_forward``,
    ``map_epoch_tolerance_nT``) against the flight's date: the EpochOffset
    when max |b| over the map is within the tolerance, else MapEpochError
    naming both fields and the implied nT (also for a missing date)."""
    t_f = measurement_epoch_decimal_year
    if not (isinstance(t_f, (int, float)) and not isinstance(t_f, bool) and math.isfinite(t_f)):
        raise MapEpochError(f"{MEASUREMENT_EPOCH_FIELD}: expected the flight's date as a decimal year, got {t_f!r}; "
                            f"without it the map's epoch ({MAP_EPOCH_FIELD} = {cfg.map.epoch_decimal_year:g}) "
                            f"cannot be checked")
    off = map_epoch_offset(cfg.map, float(t_f), bool(cfg.map_bring_forward))
    tol = cfg.map_epoch_tolerance_nT
    if abs(off.bias_worst_nT) > tol:
        hint = (f"build the map at {t_f:g}" if off.brought_forward else
                f"build the map at {t_f:g} or set geomag.map_bring_forward: true")
        raise MapEpochError(f"{off.describe()}, beyond {TOLERANCE_FIELD} = {tol:g} nT "
                            f"(geomag.field_sigma_nT = {cfg.field_sigma_nT:g} nT); {hint}")
    return off


def check_scenario(data: dict) -> EpochOffset | None:
    """The scenario validation's check (``hyper_nav_sim.core.scenario``): the
    ``geomag:`` block's map against ``magnetometer.epoch_decimal_year``."""
    if "geomag" not in data:
        return None
    from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig
    return check(GeomagConfig.from_dict(data["geomag"]), (data.get("magnetometer") or {}).get("epoch_decimal_year"))


# ---- bringing a map forward (eq. 1) ------------------------------------------------------------
def bring_forward(gmap: GeomagMap, target_epoch_decimal_year: float) -> GeomagMap:
    """The map at ``target_epoch_decimal_year``: eq. (1) on its component
    layers and their height derivatives, with Bdot of the map's release
    splined from the coarse grid, then F and dF/dh from the components as
    ``geomag_map.build_layers`` computes them (dF/dh a one-sided difference
    over dh_m)."""
    s = gmap.spec
    dt = float(target_epoch_decimal_year) - s.epoch_decimal_year
    if dt == 0.0:
        return gmap
    lat_c, lon_c = coarse_axes_deg(s)
    sv0 = _grid(lambda a, b: secular_variation_enu_nT_per_yr(a, b, s.alt_m, s.epoch_decimal_year), lat_c, lon_c)
    sv1 = _grid(lambda a, b: secular_variation_enu_nT_per_yr(a, b, s.alt_m + s.dh_m, s.epoch_decimal_year),
                lat_c, lon_c)
    lat, lon = s.axes_deg()

    def on_map(g):
        return np.stack([RectBivariateSpline(lat_c, lon_c, g[..., k])(lat, lon) for k in range(3)])
    bdot, bdot_up = on_map(sv0), on_map(sv1)
    L = gmap.layers
    b = L[1:4] + dt * bdot                                           # B_E, B_N, B_U at the target epoch
    b_dh = L[5:8] + dt * (bdot_up - bdot) / s.dh_m
    f = np.linalg.norm(b, axis=0)
    f_dh = (np.linalg.norm(b + s.dh_m * b_dh, axis=0) - f) / s.dh_m
    layers = np.concatenate([f[None], b, f_dh[None], b_dh])
    prov = dict(gmap.provenance, brought_forward_from_epoch_decimal_year=s.epoch_decimal_year,
                secular_variation_model=_release(s.epoch_decimal_year, MAP_EPOCH_FIELD).name)
    return GeomagMap(dataclasses.replace(s, epoch_decimal_year=float(target_epoch_decimal_year)), layers, prov)
