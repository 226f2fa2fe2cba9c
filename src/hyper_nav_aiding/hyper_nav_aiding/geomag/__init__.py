"""Geomagnetic matching aiding (seed 003): the node (:mod:`.node`), its declaration (:mod:`.descriptor`), its
parameters from a scenario (:mod:`.parameters`), message conversions (:mod:`.conversions`), its logic in a Monte
Carlo run (:mod:`.mc_feed`), the map builder command (:mod:`.build_map`) and the cores (:mod:`.core`: MAGCOM,
ICCP, SIMAN, EKF on intensity, the map and its epoch, the PCRB)."""
