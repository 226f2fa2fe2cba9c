"""Strapdown INS in the launch-centred inertial (LCI, 'a') frame (seed 001).

Modules: ``frames`` (launch frame, ECEF/LECI/LCI and geodetic conversions),
``gravity`` (J2 gravitation in LCI, eqs. 7-10, and a WGS-84 normal-gravity
option), ``mechanization`` (two-sample coning/sculling/scrolling update,
section 3) and ``error_model`` (15-state error model, section 4.1, and the
loosely coupled BDS/GNSS measurements converted from ECEF, section 4.3).
"""
