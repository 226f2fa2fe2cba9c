"""GNSS (GPS + BeiDou) signal simulation: broadcast ephemerides, synthetic
constellations, propagation delays, observables, PVT and a tracking-lock model.

Times are continuous seconds (GPST unless a function says "system time"; BDT =
GPST - 14 s, see ephemeris). Positions/velocities in the Earth-fixed frame (ECEF).

The receiver-side models (broadcast ephemeris, light time and Sagnac,
elevation/azimuth, Klobuchar and Hopfield) live in
:mod:`hyper_nav_filter.core.gnss`, which the filter's tightly coupled update
uses too; they are re-exported here.
"""
from hyper_nav_gnss.orbits.ephemeris import (
    BDS_GEO_PRNS, C_MPS, BroadcastEphemeris, calendar_to_system_s, constants, gpst_s, satellite_position_ecef,
    select_ephemeris, shift_ephemeris, system_time_s,
)
from hyper_nav_gnss.formats.rinex_nav import read_rinex2_nav, read_rinex3_nav
from hyper_nav_gnss.geometry import elevation_azimuth
from hyper_nav_gnss.corrections.propagation import CARRIER_HZ, F_B1I_HZ, F_L1_HZ, hopfield_delay_m, klobuchar_delay_m

from hyper_nav_gnss.orbits.constellation import (
    Visibility, is_geosynchronous, synthetic_constellation, visible_satellites,
)
from hyper_nav_gnss.receiver.lock import LockConfig, LockModel, vehicle_doppler_hz
from .observables import ClockModel, Observables, compute_observables, pr_sigma_m
from hyper_nav_gnss.positioning.pvt import PvtSolution, solve_pvt

__all__ = [
    "BDS_GEO_PRNS", "C_MPS", "CARRIER_HZ", "F_B1I_HZ", "F_L1_HZ",
    "BroadcastEphemeris", "satellite_position_ecef", "select_ephemeris", "shift_ephemeris",
    "read_rinex2_nav", "read_rinex3_nav", "system_time_s", "gpst_s", "calendar_to_system_s", "constants",
    "synthetic_constellation", "visible_satellites", "elevation_azimuth", "is_geosynchronous", "Visibility",
    "klobuchar_delay_m", "hopfield_delay_m",
    "compute_observables", "Observables", "ClockModel", "pr_sigma_m",
    "solve_pvt", "PvtSolution",
    "LockConfig", "LockModel", "vehicle_doppler_hz",
]
