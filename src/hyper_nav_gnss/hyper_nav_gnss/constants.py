"""Physical constants of GNSS, defined once for every package (filter, simulated world, workbench, studies).

IS-GPS-200 section 20.3.4.3 fixes the speed of light every GNSS interface document uses.
"""
C_MPS = 299792458.0  # speed of light in vacuum [m/s] (IS-GPS-200, 20.3.4.3)
