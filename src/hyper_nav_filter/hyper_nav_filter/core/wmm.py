"""World Magnetic Model selected by date (pygeomag's coefficient files).

Each WMM release is valid for five years from its epoch; outside that span
pygeomag refuses the date (``Time extends beyond model 5-year life span``).
The simulator therefore picks the release whose life span holds the date and
refuses, naming the field and the covered span, a date that no shipped
release covers. Shipped with pygeomag 1.x (``pygeomag/wmm/*.COF``):

    WMM-2010    2010.0 - 2015.0
    WMM-2015v2  2015.0 - 2020.0   (the out-of-cycle 2019 release; supersedes WMM-2015)
    WMM-2020    2020.0 - 2025.0
    WMM-2025    2025.0 - 2030.0

A date exactly on a boundary takes the newer release.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np


class WmmDateError(ValueError):
    """No shipped World Magnetic Model covers the date."""


@dataclass(frozen=True)
class WmmRelease:
    name: str
    start_year: float
    end_year: float
    coefficients_file: str       # relative to the pygeomag package, as GeoMag() takes it


RELEASES = (
    WmmRelease("WMM-2010", 2010.0, 2015.0, "wmm/WMM_2010.COF"),
    WmmRelease("WMM-2015v2", 2015.0, 2020.0, "wmm/WMM_2015v2.COF"),
    WmmRelease("WMM-2020", 2020.0, 2025.0, "wmm/WMM_2020.COF"),
    WmmRelease("WMM-2025", 2025.0, 2030.0, "wmm/WMM_2025.COF"),
)


def release_for(decimal_year: float, field: str = "magnetometer.epoch_decimal_year") -> WmmRelease:
    """The WMM release valid at ``decimal_year``; WmmDateError naming ``field`` otherwise."""
    y = float(decimal_year)
    for rel in reversed(RELEASES):
        if rel.start_year <= y < rel.end_year:
            return rel
    first, last = RELEASES[0], RELEASES[-1]
    raise WmmDateError(f"{field}: {decimal_year!r} is outside every World Magnetic Model available "
                       f"({first.name} .. {last.name} cover {first.start_year:.1f} to {last.end_year:.1f}, "
                       f"each for five years from its epoch)")


@functools.lru_cache(maxsize=None)
def _geomag(coefficients_file: str):
    from pygeomag import GeoMag
    return GeoMag(coefficients_file=coefficients_file)


def field_enu_nT(lat_rad, lon_rad, alt_m, decimal_year) -> np.ndarray:
    """WMM main field in ENU [nT] at one geodetic point (altitude above the
    ellipsoid in metres), from the release valid at ``decimal_year``.
    pygeomag returns north/east/down; mapped to (E, N, -D)."""
    rel = release_for(decimal_year)
    lon_deg = float(np.rad2deg(lon_rad))
    lon_deg = (lon_deg + 180.0) % 360.0 - 180.0
    r = _geomag(rel.coefficients_file).calculate(glat=float(np.rad2deg(lat_rad)), glon=lon_deg,
                                                 alt=float(alt_m) / 1000.0, time=float(decimal_year))
    return np.array([r.y, r.x, -r.z])
