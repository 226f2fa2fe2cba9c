"""Virtual GNSS under lock loss (seed 004 section 2.3): the node (:mod:`.node`), its declaration
(:mod:`.descriptor`), parameters (:mod:`.parameters`), input handling shared by node and replay (:mod:`.input`),
message conversions (:mod:`.conversions`), offline runs (:mod:`.offline`) and the cores (:mod:`.core`: the state
machine, virtual pseudoranges eqs. 8-11, alpha-beta and fused extrapolation, the configuration)."""
