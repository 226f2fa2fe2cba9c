"""Lever-arm frequency re-estimation, RL-DLAC (seed 000): the node (:mod:`.node`), its declaration
(:mod:`.descriptor`), message conversions (:mod:`.conversions`), windows cut from a simulated flight for studies
and tests (:mod:`.sim_windows`) and the cores (:mod:`.core`: trigger, window, DDPG, identifiers, CRB, worker)."""
