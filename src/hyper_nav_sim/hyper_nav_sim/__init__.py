"""hyper_nav_sim: the simulated world (truth, sensor models and nodes, the GNSS world, scenarios)."""
from hyper_nav_filter.moved import install as _install_moved

_install_moved()          # an old module name (before the packages were arranged by role) says where it went
