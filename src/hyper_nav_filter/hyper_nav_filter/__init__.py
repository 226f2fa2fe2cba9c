"""hyper_nav_filter: strapdown INS and error-state Kalman filter (cores in ``core/``, the fusion node, declared sources)."""
from hyper_nav_filter.moved import install as _install_moved

_install_moved()          # an old module name (before the packages were arranged by role) says where it went
