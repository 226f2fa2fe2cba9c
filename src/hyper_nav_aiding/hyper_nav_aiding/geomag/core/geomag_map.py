"""Geomagnetic reference map: the World Magnetic Model (pygeomag) sampled at
one altitude over a latitude/longitude region, cached on disk with its
provenance, interpolated with gradients (seed 003 section 4).

Seed 003 builds the map from WMM at 25 km over 40-48N, 109-112E on a
0.01 deg grid and refines it by interpolation to 0.00125 deg. Here the base
grid (``grid_step_deg``) is what pygeomag computes and what is stored; the
refinement is a bicubic spline through it (scipy ``RectBivariateSpline``),
whose values at the refined nodes (``grid_step_deg / refine_factor``) are the
refined map. The matchers use the refined grid for their geometry (MAGCOM
translation steps, ICCP area, SIMAN nine-point plane fit) and the spline for
values and gradients anywhere. The WMM main field at 25 km has no structure
shorter than ~3000 km, so the spline reproduces pygeomag to better than
1e-4 nT between base nodes (checked by a test); all map error in the
simulation is the simulator's own ``MapErrorField``, not interpolation.

Layers (nT, and nT/m for the vertical derivatives), ENU like the rest of the
project (pygeomag's X north, Y east, Z down mapped to E = Y, N = X, U = -Z)::

    F, B_E, B_N, B_U, dF_dh, dB_E_dh, dB_N_dh, dB_U_dh

The vertical derivatives (one-sided difference over ``dh_m``) carry the map
to the flight altitude: F(lat, lon, h) = F + dF_dh (h - alt_m). At 25 km the
total field falls by ~25 nT per km of height (about -3 F / r), i.e. seven
times its horizontal gradient (3-4.5 nT/km): a map used 1 km off its
altitude without this term would be off by kilometres. The second-order term
is below 0.01 nT for 1 km.

Provenance stored with the grids: model name (``WMM-2025``), pygeomag
version, epoch (decimal year), altitude, region, step, refine factor, dh.
``load_map(path, expected_spec)`` refuses a file whose provenance differs
(``MapMismatchError`` naming the field) or that is unreadable or holds
non-finite values (``MapFileError``).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import pathlib
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RectBivariateSpline

from hyper_nav_filter.core.params import FLOAT, INT, checked
from hyper_nav_gnss import earth

LAYERS = ("F", "B_E", "B_N", "B_U", "dF_dh", "dB_E_dh", "dB_N_dh", "dB_U_dh")
FORMAT_VERSION = 1


class MapError(ValueError):
    """Base class of the map errors (the message says what and where)."""


class MapFileError(MapError):
    """The map file is missing, unreadable, incomplete or holds non-finite values."""


class MapMismatchError(MapError):
    """The map's provenance differs from what the scenario asks for."""


class OffMapError(MapError):
    """A position (or a matching area) lies outside the map."""


@dataclass(frozen=True)
class MapSpec:
    """What a map is: model, epoch, altitude and grid (seed 003 section 4)."""
    model: str = "WMM-2025"
    epoch_decimal_year: float = 2025.5
    alt_m: float = 25000.0
    lat_min_deg: float = 40.0
    lat_max_deg: float = 48.0
    lon_min_deg: float = 109.0
    lon_max_deg: float = 112.0
    grid_step_deg: float = 0.01
    refine_factor: int = 8
    dh_m: float = 100.0

    def __post_init__(self):
        for f in ("epoch_decimal_year", "alt_m", "lat_min_deg", "lat_max_deg", "lon_min_deg", "lon_max_deg",
                  "grid_step_deg", "dh_m"):
            checked(f"map.{f}", getattr(self, f), FLOAT, error=MapError)
        if not isinstance(self.model, str) or not self.model:
            raise MapError(f"map.model: expected a model name, got {self.model!r}")
        checked("map.refine_factor", self.refine_factor, INT, lo=1, error=MapError)
        if not -90.0 <= self.lat_min_deg < self.lat_max_deg <= 90.0:
            raise MapError(f"map.lat_min_deg/lat_max_deg: need -90 <= min < max <= 90, "
                           f"got {self.lat_min_deg}, {self.lat_max_deg}")
        if not self.lon_min_deg < self.lon_max_deg:
            raise MapError(f"map.lon_min_deg/lon_max_deg: need min < max, got {self.lon_min_deg}, {self.lon_max_deg}")
        if self.grid_step_deg <= 0 or self.dh_m <= 0:
            raise MapError("map.grid_step_deg and map.dh_m must be > 0")
        for lo, hi, what in ((self.lat_min_deg, self.lat_max_deg, "lat"), (self.lon_min_deg, self.lon_max_deg, "lon")):
            n = (hi - lo) / self.grid_step_deg
            if abs(n - round(n)) > 1e-6 or round(n) < 3:
                raise MapError(f"map.grid_step_deg: the {what} extent {hi - lo} deg is not a whole number "
                               f"(>= 3) of steps of {self.grid_step_deg} deg")

    @classmethod
    def from_dict(cls, d: dict, prefix: str = "map") -> "MapSpec":
        known = {f.name for f in dataclasses.fields(cls)}
        if not isinstance(d, dict):
            raise MapError(f"{prefix}: expected a mapping, got {d!r}")
        unknown = sorted(set(d) - known)
        if unknown:
            raise MapError(f"{prefix}: unknown field(s) {unknown} (known: {sorted(known)})")
        try:
            return cls(**d)
        except MapError as exc:
            raise MapError(str(exc).replace("map.", f"{prefix}.", 1)) from None

    @property
    def refined_step_deg(self) -> float:
        return self.grid_step_deg / self.refine_factor

    def shape(self) -> tuple[int, int]:
        return (int(round((self.lat_max_deg - self.lat_min_deg) / self.grid_step_deg)) + 1,
                int(round((self.lon_max_deg - self.lon_min_deg) / self.grid_step_deg)) + 1)

    def axes_deg(self) -> tuple[np.ndarray, np.ndarray]:
        n_lat, n_lon = self.shape()
        return (self.lat_min_deg + self.grid_step_deg * np.arange(n_lat),
                self.lon_min_deg + self.grid_step_deg * np.arange(n_lon))

    def key(self) -> str:
        """Short content hash: the cache file name."""
        s = json.dumps(dataclasses.asdict(self), sort_keys=True)
        return hashlib.sha256(s.encode()).hexdigest()[:16]

    def mismatch(self, other: "MapSpec") -> str | None:
        """The first field in which ``other`` (a file's provenance) differs
        from this spec, as a message; None when they agree."""
        for f in dataclasses.fields(self):
            a, b = getattr(self, f.name), getattr(other, f.name)
            same = a == b if isinstance(a, (str, int)) and not isinstance(a, float) else \
                abs(float(a) - float(b)) <= 1e-9 * max(1.0, abs(float(a)))
            if not same:
                return f"{f.name} is {b!r} in the map file but {a!r} is expected"
        return None


def _wmm(decimal_year: float):
    """pygeomag with the WMM release valid at the date (the simulator's choice,
    ``hyper_nav_filter.core.wmm``), so map and magnetometer use the same model."""
    from pygeomag import GeoMag
    from hyper_nav_filter.core.wmm import release_for
    return GeoMag(coefficients_file=release_for(decimal_year, "map.epoch_decimal_year").coefficients_file)


def wmm_model_name(decimal_year: float = 2025.5) -> str:
    return _wmm(decimal_year).model


def _wmm_rows(args):
    """pygeomag over a block of latitude rows: (rows, n_lon, 8) layers."""
    lats, lons, alt_km, dh_km, year = args
    gm = _wmm(year)
    out = np.empty((len(lats), len(lons), 8))
    for i, la in enumerate(lats):
        for j, lo in enumerate(lons):
            r0 = gm.calculate(glat=float(la), glon=float(lo), alt=alt_km, time=year)
            r1 = gm.calculate(glat=float(la), glon=float(lo), alt=alt_km + dh_km, time=year)
            b0 = (r0.f, r0.y, r0.x, -r0.z)
            b1 = (r1.f, r1.y, r1.x, -r1.z)
            out[i, j, :4] = b0
            out[i, j, 4:] = [(x1 - x0) / (dh_km * 1000.0) for x0, x1 in zip(b0, b1)]
    return out


def build_layers(spec: MapSpec, workers: int = 1) -> np.ndarray:
    """pygeomag on the base grid: array (8, n_lat, n_lon). About 180 us per
    node (two pygeomag calls of ~90 us each, measured): 43 s for seed 003's
    801 x 301 grid on one core; ``workers`` > 1 splits rows over processes."""
    model = wmm_model_name(spec.epoch_decimal_year)
    if model != spec.model:
        raise MapMismatchError(f"map.model: pygeomag provides {model!r}, the scenario asks for {spec.model!r}")
    lat, lon = spec.axes_deg()
    args = [(rows, lon, spec.alt_m / 1000.0, spec.dh_m / 1000.0, spec.epoch_decimal_year)
            for rows in np.array_split(lat, max(1, workers) * 4)]
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor
        with ProcessPoolExecutor(max_workers=workers) as ex:
            blocks = list(ex.map(_wmm_rows, args))
    else:
        blocks = [_wmm_rows(a) for a in args]
    return np.moveaxis(np.concatenate(blocks, axis=0), -1, 0).copy()


class GeomagMap:
    """A built or loaded map: base-grid layers and their bicubic splines."""

    def __init__(self, spec: MapSpec, layers: np.ndarray, provenance: dict | None = None):
        n_lat, n_lon = spec.shape()
        if layers.shape != (len(LAYERS), n_lat, n_lon):
            raise MapFileError(f"map layers have shape {layers.shape}, expected {(len(LAYERS), n_lat, n_lon)}")
        if not np.all(np.isfinite(layers)):
            raise MapFileError(f"map layers hold {int(np.sum(~np.isfinite(layers)))} non-finite values")
        self.spec = spec
        self.layers = layers
        self.provenance = dict(provenance or {})
        lat, lon = spec.axes_deg()
        self._splines = {name: RectBivariateSpline(lat, lon, layers[i], kx=3, ky=3)
                         for i, name in enumerate(LAYERS)}
        # derivative splines, built once: RectBivariateSpline.ev(dx=1) differentiates the
        # whole coefficient array on every call (277 us per point on the 801 x 301 map,
        # measured), the derived spline evaluates in 2 us
        self._derived = {(name, a, b): sp.partial_derivative(a, b) for name, sp in self._splines.items()
                         for a, b in ((1, 0), (0, 1))}

    # ---- construction / files ----------------------------------------------------
    @classmethod
    def build(cls, spec: MapSpec, workers: int = 1) -> "GeomagMap":
        from importlib.metadata import version
        prov = {"source": "pygeomag", "pygeomag_version": version("pygeomag"), "layers": list(LAYERS)}
        return cls(spec, build_layers(spec, workers), prov)

    def save(self, path: str | os.PathLike) -> pathlib.Path:
        path = pathlib.Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        meta = {"format_version": FORMAT_VERSION, "spec": dataclasses.asdict(self.spec), **self.provenance}
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp.npz")     # two builders never share a temp file
        np.savez(tmp, layers=self.layers, provenance=np.array(json.dumps(meta)))
        os.replace(tmp, path)
        return path

    # ---- queries -----------------------------------------------------------------
    def contains(self, lat_rad, lon_rad, margin_deg: float = 0.0) -> np.ndarray:
        """True where the point is inside the map by at least margin_deg (the
        spline needs no margin; matchers ask for their search area)."""
        la, lo = np.rad2deg(lat_rad), np.rad2deg(lon_rad)
        s = self.spec
        return ((la >= s.lat_min_deg + margin_deg) & (la <= s.lat_max_deg - margin_deg)
                & (lo >= s.lon_min_deg + margin_deg) & (lo <= s.lon_max_deg - margin_deg))

    def _check(self, lat_rad, lon_rad):
        if not np.all(self.contains(lat_rad, lon_rad)):
            la, lo = np.rad2deg(np.atleast_1d(lat_rad)), np.rad2deg(np.atleast_1d(lon_rad))
            bad = ~self.contains(np.deg2rad(la), np.deg2rad(lo))
            s = self.spec
            raise OffMapError(f"position {la[bad][0]:.4f} deg N {lo[bad][0]:.4f} deg E is outside the map "
                              f"({s.lat_min_deg}-{s.lat_max_deg} N, {s.lon_min_deg}-{s.lon_max_deg} E)")

    def layer(self, name: str, lat_deg, lon_deg, d_lat: int = 0, d_lon: int = 0) -> np.ndarray:
        """Spline value (or first derivative per degree) of one layer at degrees, no bounds check."""
        if d_lat or d_lon:
            return self._derived[(name, d_lat, d_lon)](lat_deg, lon_deg, grid=False)
        return self._splines[name].ev(lat_deg, lon_deg)

    def total_nT(self, lat_rad, lon_rad, alt_m) -> np.ndarray:
        """Total intensity F [nT] at geodetic points (broadcast arrays),
        carried from the map altitude with dF/dh. OffMapError outside."""
        self._check(lat_rad, lon_rad)
        la, lo = np.rad2deg(lat_rad), np.rad2deg(lon_rad)
        return self.layer("F", la, lo) + self.layer("dF_dh", la, lo) * (np.asarray(alt_m, float) - self.spec.alt_m)

    def total_on_map_surface_nT(self, lat_deg, lon_deg) -> np.ndarray:
        """F at the map altitude, degrees in, no bounds check (the matchers'
        inner loops, after they checked their search area)."""
        return self._splines["F"].ev(lat_deg, lon_deg)

    def total_and_gradient(self, lat_rad, lon_rad, alt_m):
        """(F [nT], gradient [dF/dE, dF/dN, dF/dU] in nT/m, shape (..., 3))."""
        self._check(lat_rad, lon_rad)
        la, lo = np.rad2deg(lat_rad), np.rad2deg(lon_rad)
        dh = np.asarray(alt_m, float) - self.spec.alt_m
        r_m, r_n = earth.radii(np.asarray(lat_rad, float))
        h = np.asarray(alt_m, float)
        deg = np.pi / 180.0
        f = self.layer("F", la, lo) + self.layer("dF_dh", la, lo) * dh
        d_lat = (self.layer("F", la, lo, d_lat=1) + self.layer("dF_dh", la, lo, d_lat=1) * dh) / deg
        d_lon = (self.layer("F", la, lo, d_lon=1) + self.layer("dF_dh", la, lo, d_lon=1) * dh) / deg
        g = np.stack([d_lon / ((r_n + h) * np.cos(lat_rad)), d_lat / (r_m + h),
                      self.layer("dF_dh", la, lo) * np.ones_like(dh)], axis=-1)
        return f, g

    def vector_enu_nT(self, lat_rad, lon_rad, alt_m) -> np.ndarray:
        """Field components (E, N, U) [nT], shape (..., 3)."""
        self._check(lat_rad, lon_rad)
        la, lo = np.rad2deg(lat_rad), np.rad2deg(lon_rad)
        dh = np.asarray(alt_m, float) - self.spec.alt_m
        return np.stack([self.layer(c, la, lo) + self.layer(f"d{c}_dh", la, lo) * dh
                         for c in ("B_E", "B_N", "B_U")], axis=-1)

    def refined_window(self, lat_c_deg: float, lon_c_deg: float, half_cells: int):
        """The refined grid nodes around the node nearest (lat_c, lon_c):
        (lat_deg (n,), lon_deg (m,), F at the map altitude (n, m)). Raises
        OffMapError when the window leaves the map."""
        s = self.spec
        st = s.refined_step_deg
        i0 = round((lat_c_deg - s.lat_min_deg) / st)
        j0 = round((lon_c_deg - s.lon_min_deg) / st)
        lat = s.lat_min_deg + st * np.arange(i0 - half_cells, i0 + half_cells + 1)
        lon = s.lon_min_deg + st * np.arange(j0 - half_cells, j0 + half_cells + 1)
        if lat[0] < s.lat_min_deg - 1e-9 or lat[-1] > s.lat_max_deg + 1e-9 or \
                lon[0] < s.lon_min_deg - 1e-9 or lon[-1] > s.lon_max_deg + 1e-9:
            raise OffMapError(f"matching area of {2 * half_cells + 1} x {2 * half_cells + 1} cells around "
                              f"{lat_c_deg:.4f} N {lon_c_deg:.4f} E leaves the map "
                              f"({s.lat_min_deg}-{s.lat_max_deg} N, {s.lon_min_deg}-{s.lon_max_deg} E)")
        return lat, lon, self._splines["F"](lat, lon)


def load_map(path: str | os.PathLike, expected: MapSpec | None = None) -> GeomagMap:
    """Read a map file; with ``expected`` refuse one built for another model,
    epoch, altitude or grid (MapMismatchError naming the field)."""
    path = pathlib.Path(path)
    if not path.exists():
        raise MapFileError(f"map file {path} does not exist")
    try:
        with np.load(path, allow_pickle=False) as z:
            layers = np.asarray(z["layers"], float)
            meta = json.loads(str(z["provenance"]))
        spec = MapSpec(**meta["spec"])
    except MapError as exc:
        raise MapFileError(f"map file {path}: bad provenance: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - any unreadable file is one kind of error for the user
        raise MapFileError(f"map file {path} is not a readable geomagnetic map ({type(exc).__name__}: {exc})") from None
    if meta.get("format_version") != FORMAT_VERSION:
        raise MapFileError(f"map file {path}: format_version {meta.get('format_version')!r}, "
                           f"expected {FORMAT_VERSION}")
    if expected is not None:
        why = expected.mismatch(spec)
        if why is not None:
            raise MapMismatchError(f"map file {path} does not match the scenario: {why}")
    try:
        return GeomagMap(spec, layers, {k: v for k, v in meta.items() if k not in ("spec", "format_version")})
    except MapFileError as exc:
        raise MapFileError(f"map file {path}: {exc}") from None


def default_cache_dir() -> pathlib.Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return pathlib.Path(base) / "hyper_nav" / "geomag"


def cached_map_path(spec: MapSpec, cache_dir: str | os.PathLike | None = None) -> pathlib.Path:
    d = pathlib.Path(cache_dir) if cache_dir else default_cache_dir()
    return d / f"wmm_{spec.model}_{spec.alt_m:.0f}m_{spec.key()}.npz"


def get_or_build(spec: MapSpec, cache_dir: str | os.PathLike | None = None, workers: int = 1,
                 log=None) -> GeomagMap:
    """The cached map for ``spec``, built (and saved) on first use."""
    path = cached_map_path(spec, cache_dir)
    if path.exists():
        return load_map(path, spec)
    if log:
        n = spec.shape()
        log(f"building geomagnetic map {n[0]} x {n[1]} nodes with pygeomag -> {path}")
    m = GeomagMap.build(spec, workers)
    m.save(path)
    return m
