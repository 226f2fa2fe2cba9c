"""hyper_nav_gnss: the receiver-side GNSS library (pure numpy, no rclpy; it imports no other hyper-nav package).

One home per GNSS concept, the bottom floor that the filter, the simulator and the workbench all use:

* :mod:`.constants` physical constants (speed of light, defined once); :mod:`.earth` the WGS-84 Earth model;
* :mod:`.signals` signal plans and carriers; :mod:`.geometry` light time, Sagnac, elevation/azimuth;
* :mod:`.formats` file and stream readers (RINEX 2/3/4 observation and navigation, UBX, navigation messages),
  chosen through one registry keyed by format (:mod:`.formats.registry`);
* :mod:`.orbits` broadcast ephemerides, synthetic and nominal constellations;
* :mod:`.corrections` ionosphere/troposphere, code biases, combinations and the per-signal receiver model;
* :mod:`.positioning` single-point positioning, RAIM, weighting;
* :mod:`.receiver` the receiver's tracking loops, acquisition, lock model, INS aiding input and signal environment.
"""
