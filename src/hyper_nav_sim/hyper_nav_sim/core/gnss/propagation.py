"""Moved to :mod:`hyper_nav_filter.core.gnss.propagation` (the receiver removes
the same broadcast models in the filter's tightly coupled update); re-exported
here so ``hyper_nav_sim.core.gnss.propagation`` keeps working."""
from hyper_nav_filter.core.gnss.propagation import (  # noqa: F401
    C_MPS, CARRIER_HZ, F_B1I_HZ, F_L1_HZ, hopfield_delay_m, klobuchar_delay_m)
