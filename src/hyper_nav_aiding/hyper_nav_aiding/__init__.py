"""hyper_nav_aiding: navigation aiding nodes for hyper-nav, one folder each.

  geomag/        geomagnetic matching (MAGCOM, ICCP, SIMAN, EKF on intensity; seed 003)
  virtual_gnss/  virtual GNSS pseudoranges under lock loss (seed 004 section 2.3)
  lever_arm/     re-estimation of the elastic lever arm's natural frequencies (RL-DLAC, seed 000)

Each folder holds its node (``node.py``, a thin rclpy wrapper), its declaration to the launcher and the scenario
loader (``descriptor.py``, entry-point group ``hyper_nav.aiding_nodes``), its message conversions and its pure
cores (``core/``, numpy/scipy, no rclpy). The nodes run without the simulator installed; the offline helpers over
simulated flights (``virtual_gnss/offline.py``, ``lever_arm/sim_windows.py``, ``geomag/mc_feed.py``) import it
when used. The paper reproductions that use these cores are in the ``hyper_nav_repro`` package.
"""
from hyper_nav_filter.moved import install as _install_moved

_install_moved()          # an old module name (before the packages were arranged by role) says where it went
