"""Receiver-side GNSS models for the tightly coupled filter (pure numpy, no
rclpy, no simulator import):

* :mod:`.ephemeris` broadcast ephemeris orbits and satellite clocks (GPS/BDS),
  RINEX navigation readers, time scales;
* :mod:`.geometry` light-time (transmit-time) solution with Sagnac rotation,
  elevation/azimuth;
* :mod:`.propagation` Klobuchar ionosphere and Hopfield troposphere models;
* :mod:`.raw_to_pseudoranges` raw receiver epochs + ephemerides -> corrected
  :class:`~hyper_nav_filter.core.tightly_coupled.Pseudoranges` measurements.

The simulator (``hyper_nav_sim.core.gnss``) generates its observables with
these same models and re-exports them.
"""
