"""Moved to :mod:`hyper_nav_filter.core.gnss.ephemeris` (the filter's tightly
coupled update needs it and must not import the simulator); re-exported here
so ``hyper_nav_sim.core.gnss.ephemeris`` keeps working."""
from hyper_nav_filter.core.gnss.ephemeris import (  # noqa: F401
    BDS_GEO_PRNS, BDT_MINUS_GPST_S, BDT_WEEK_OFFSET, C_MPS, MU_BDS_M3PS2, MU_GPS_M3PS2, OMEGA_E_BDS_RADPS,
    OMEGA_E_GPS_RADPS, SECONDS_PER_WEEK, BroadcastEphemeris, _kepler_E, calendar_to_system_s, constants, gpst_s,
    read_rinex2_nav, read_rinex3_nav, satellite_position_ecef, select_ephemeris, shift_ephemeris, system_time_s)
