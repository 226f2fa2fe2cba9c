"""Strapdown INS in the launch-centred inertial (LCI, 'a') frame (seed 001).

Modules: ``frames`` (launch frame, ECEF/LECI/LCI and geodetic conversions),
``gravity`` (J2 gravitation in LCI, eqs. 7-10, and a WGS-84 normal-gravity
option), ``mechanization`` (two-sample coning/sculling/scrolling update,
section 3). The filter's LCI frame (nominal state, 15-state error model of
section 4.1, transform of the errors into the ENU convention so that every
measurement model applies) is ``core.frames.lci``.
"""
