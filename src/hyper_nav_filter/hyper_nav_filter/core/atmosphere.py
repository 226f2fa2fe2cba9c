"""U.S. Standard Atmosphere 1976: temperature, pressure, density, speed of sound.

Vectorised over geometric altitude z [m] (numpy arrays or scalars).

* 0 <= z <= 86 km: the seven geopotential layers of the 1976 standard
  (base geopotential heights 0, 11, 20, 32, 47, 51, 71 km', top 84.852 km'),
  hydrostatic pressure, density rho = P M0 / (R* T_M). The temperature
  returned is the molecular-scale temperature T_M; it equals the kinetic
  temperature below 80 km and exceeds it by at most 0.04 % at 86 km (the
  standard's molecular-weight ratio M/M0 goes from 1 to 0.999579 there),
  which we neglect.
* 86 km < z <= 120 km: the 1976 tables (U.S. Standard Atmosphere 1976,
  NOAA-S/T 76-1562, Table I) at 86, 90, 95, 100, 105, 110, 115, 120 km,
  log-linearly interpolated in pressure and density (exponential between the
  nodes, i.e. a piecewise constant scale height) and linearly in kinetic
  temperature. This is an extension for the sake of continuity (the vehicles
  here fly below 86 km except ballistic arcs of the boost phase); the 1976
  model above 86 km solves a diffusion model that we do not reproduce.
* z > 120 km: exponential extrapolation with the 115-120 km scale heights.
* z < 0: the first layer's formulae (valid down to about -5 km).

The speed of sound is sqrt(gamma R* T_M / M0) with gamma = 1.4 (a continuum
quantity, only meaningful below ~86 km).

``density_kgpm3_scalar`` and ``altitude_for_density_m_scalar`` are the
scalar fast paths of ``density_kgpm3`` and ``altitude_for_density_m`` (the
same formulae on one float, plain ``math``: the point-mass flight dynamics
call them once per ODE right-hand side; a test compares them with the
vectorised functions).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

R_STAR = 8.31432          # J/(mol K), universal gas constant as in the 1976 standard
M0 = 28.9644e-3           # kg/mol, sea-level mean molar mass
G0 = 9.80665              # m/s^2
R0_M = 6356766.0          # m, effective Earth radius for geopotential height
GAMMA_AIR = 1.4
R_AIR = R_STAR / M0       # 287.053 J/(kg K)

# geopotential base heights [m'], lapse rates [K/m'], base temperatures [K], base pressures [Pa]
_H_B = np.array([0.0, 11000.0, 20000.0, 32000.0, 47000.0, 51000.0, 71000.0, 84852.0])
_L_B = np.array([-6.5e-3, 0.0, 1.0e-3, 2.8e-3, 0.0, -2.8e-3, -2.0e-3])
_T_B = np.empty(7)
_P_B = np.empty(7)
_T_B[0], _P_B[0] = 288.15, 101325.0
for _i in range(6):
    _dh = _H_B[_i + 1] - _H_B[_i]
    _T_B[_i + 1] = _T_B[_i] + _L_B[_i] * _dh
    if _L_B[_i] == 0.0:
        _P_B[_i + 1] = _P_B[_i] * np.exp(-G0 * M0 * _dh / (R_STAR * _T_B[_i]))
    else:
        _P_B[_i + 1] = _P_B[_i] * (_T_B[_i] / _T_B[_i + 1]) ** (G0 * M0 / (R_STAR * _L_B[_i]))

Z_TOP_LAYERS_M = R0_M * _H_B[-1] / (R0_M - _H_B[-1])     # 86 km geometric (85999.7 m)

# 1976 Table I above 86 km: geometric altitude [m], kinetic T [K], P [Pa], rho [kg/m^3]
_UPPER = np.array([
    [86000.0, 186.87, 3.7338e-1, 6.958e-6],
    [90000.0, 186.87, 1.8359e-1, 3.416e-6],
    [95000.0, 188.42, 7.5966e-2, 1.393e-6],
    [100000.0, 195.08, 3.2011e-2, 5.604e-7],
    [105000.0, 208.84, 1.4445e-2, 2.325e-7],
    [110000.0, 240.00, 7.1042e-3, 9.708e-8],
    [115000.0, 300.00, 4.0096e-3, 4.289e-8],
    [120000.0, 360.00, 2.5382e-3, 2.222e-8],
])


def geopotential_height_m(z_m):
    """Geopotential height H [m'] of geometric altitude z [m]."""
    z_m = np.asarray(z_m, dtype=float)
    return R0_M * z_m / (R0_M + z_m)


def _layers(z_m):
    """(T_M, P) from the geopotential layers; valid for z <= 86 km."""
    H = geopotential_height_m(z_m)
    i = np.clip(np.searchsorted(_H_B, H, side="right") - 1, 0, 6)
    Tb, Pb, Lb, Hb = _T_B[i], _P_B[i], _L_B[i], _H_B[i]
    dh = H - Hb
    T = Tb + Lb * dh
    iso = Lb == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        p_grad = Pb * (Tb / T) ** (G0 * M0 / (R_STAR * np.where(iso, 1.0, Lb)))
    p_iso = Pb * np.exp(-G0 * M0 * dh / (R_STAR * Tb))
    return T, np.where(iso, p_iso, p_grad)


def _upper(z_m):
    """(T, P, rho) above 86 km: log-linear interpolation/extrapolation of Table I."""
    z = _UPPER[:, 0]
    i = np.clip(np.searchsorted(z, z_m, side="right") - 1, 0, len(z) - 2)
    w = (z_m - z[i]) / (z[i + 1] - z[i])
    T = np.where(z_m <= z[-1], _UPPER[i, 1] + w * (_UPPER[i + 1, 1] - _UPPER[i, 1]), _UPPER[-1, 1])
    lp = np.log(_UPPER[i, 2]) + w * (np.log(_UPPER[i + 1, 2]) - np.log(_UPPER[i, 2]))
    lr = np.log(_UPPER[i, 3]) + w * (np.log(_UPPER[i + 1, 3]) - np.log(_UPPER[i, 3]))
    return T, np.exp(lp), np.exp(lr)


def atmosphere(z_m):
    """(temperature_K, pressure_Pa, density_kgpm3, speed_of_sound_mps) at
    geometric altitude z_m [m]; arrays of the shape of z_m."""
    z_m = np.asarray(z_m, dtype=float)
    T_lo, P_lo = _layers(np.minimum(z_m, Z_TOP_LAYERS_M))
    rho_lo = P_lo * M0 / (R_STAR * T_lo)
    T_hi, P_hi, rho_hi = _upper(np.maximum(z_m, _UPPER[0, 0]))
    hi = z_m > Z_TOP_LAYERS_M
    T = np.where(hi, T_hi, T_lo)
    P = np.where(hi, P_hi, P_lo)
    rho = np.where(hi, rho_hi, rho_lo)
    a = np.sqrt(GAMMA_AIR * R_AIR * T_lo)      # T_lo is frozen at its 86 km value above
    return T, P, rho, a


class AtmosphereState(NamedTuple):
    temperature_K: np.ndarray
    pressure_pa: np.ndarray
    density_kgpm3: np.ndarray
    speed_of_sound_mps: np.ndarray


def us76(z_m) -> AtmosphereState:
    """:func:`atmosphere` as a named tuple (``.pressure_pa`` etc.)."""
    return AtmosphereState(*atmosphere(z_m))


def temperature_K(z_m):
    return atmosphere(z_m)[0]


def pressure_Pa(z_m):
    return atmosphere(z_m)[1]


def density_kgpm3(z_m):
    return atmosphere(z_m)[2]


def speed_of_sound_mps(z_m):
    return atmosphere(z_m)[3]


_RHO_B = _P_B * M0 / (R_STAR * _T_B)      # base densities of the geopotential layers
_C = G0 * M0 / R_STAR


def _altitude_where(x, x_base, upper_col: int, density: bool):
    """Geometric altitude [m] where pressure (or density) equals x, exact per
    geopotential layer below 86 km: x / x_b = (T_b / T)^k with k = c / L for
    pressure and c / L + 1 for density (c = g0 M0 / R*), exp(-c dh / T_b) in
    isothermal layers; log-linear in the 1976 table above."""
    x = np.asarray(x, dtype=float)
    i = np.clip(np.searchsorted(-x_base, -x, side="right") - 1, 0, 6)
    Tb, Lb, xb, Hb = _T_B[i], _L_B[i], x_base[i], _H_B[i]
    iso = Lb == 0.0
    Ls = np.where(iso, 1.0, Lb)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        k = _C / Ls + (1.0 if density else 0.0)
        dh_grad = (Tb * (x / xb) ** (-1.0 / k) - Tb) / Ls
    dh_iso = -Tb * np.log(x / xb) / _C
    H = Hb + np.where(iso, dh_iso, dh_grad)
    z_lo = R0_M * H / (R0_M - H)
    lx = np.log(_UPPER[:, upper_col])
    j = np.clip(np.searchsorted(-lx, -np.log(x), side="right") - 1, 0, len(lx) - 2)
    w = (np.log(x) - lx[j]) / (lx[j + 1] - lx[j])
    z_hi = _UPPER[j, 0] + w * (_UPPER[j + 1, 0] - _UPPER[j, 0])
    return np.where(x < _UPPER[0, upper_col], z_hi, z_lo)


def altitude_for_density_m(rho_kgpm3):
    """Geometric altitude [m] at which the density is rho: the exact inverse of
    :func:`density_kgpm3` (closed form in each layer, so it is smooth inside
    the layers and continuous everywhere; used by the glide guidance)."""
    return _altitude_where(rho_kgpm3, _RHO_B, 3, density=True)


def pressure_altitude_m(p_pa):
    """Geometric altitude [m] at which the US76 pressure is p: the exact
    inverse of :func:`pressure_Pa`. This is the altimeter model of a
    barometric height measurement (``hyper_nav_filter.sources``)."""
    return _altitude_where(p_pa, _P_B, 2, density=False)


def pressure_height_gradient_pa_per_m(z_m):
    """dp/dz = -rho g (hydrostatic, Pa/m) at geometric altitude z: maps a
    pressure variance into an altitude variance."""
    T, P, rho, _ = atmosphere(z_m)
    g = G0 * (R0_M / (R0_M + np.asarray(z_m, float))) ** 2
    return -rho * g


# ---- scalar fast paths (one float in, one float out; the same formulae) ----------------
def density_kgpm3_scalar(z_m: float) -> float:
    """:func:`density_kgpm3` of one altitude [m], without array overhead."""
    if z_m > Z_TOP_LAYERS_M:
        return float(density_kgpm3(z_m))
    H = R0_M * z_m / (R0_M + z_m)
    i = 0
    while i < 6 and H >= _H_B[i + 1]:
        i += 1
    Tb, Pb, Lb = _T_B[i], _P_B[i], _L_B[i]
    dh = H - _H_B[i]
    T = Tb + Lb * dh
    P = Pb * math.exp(-_C * dh / Tb) if Lb == 0.0 else Pb * (Tb / T) ** (_C / Lb)
    return P * M0 / (R_STAR * T)


def altitude_for_density_m_scalar(rho_kgpm3: float) -> float:
    """:func:`altitude_for_density_m` of one density [kg/m^3], without array overhead."""
    if rho_kgpm3 < _UPPER[0, 3]:
        return float(altitude_for_density_m(rho_kgpm3))
    i = 0
    while i < 6 and rho_kgpm3 <= _RHO_B[i + 1]:
        i += 1
    Tb, Lb, Hb = _T_B[i], _L_B[i], _H_B[i]
    if Lb == 0.0:
        H = Hb - Tb * math.log(rho_kgpm3 / _RHO_B[i]) / _C
    else:
        H = Hb + (Tb * (rho_kgpm3 / _RHO_B[i]) ** (-1.0 / (_C / Lb + 1.0)) - Tb) / Lb
    return R0_M * H / (R0_M - H)
