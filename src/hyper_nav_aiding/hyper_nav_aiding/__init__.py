"""hyper_nav_aiding: navigation aiding for hyper-nav.

Layout (same core/wrapper split as the other packages):
  core/   pure numpy/scipy algorithms, no rclpy:
          geomagnetic matching (MAGCOM, ICCP, SIMAN; seed 003), virtual GNSS
          pseudoranges under lock loss (seed 004), DDPG re-estimation of the
          elastic lever-arm natural frequencies (seed 000)
  nodes/  thin rclpy nodes publishing aiding measurements to the fusion node

Virtual GNSS (issue #8): core/virtual_gnss.py (state machine: stored
ephemerides, lock-loss detection, nothing stale), core/virtual_pseudoranges.py
(eqs. 8-11), core/alpha_beta.py and core/fused_extrapolation.py (vehicle
position sources), core/virtual_gnss_config.py; nodes/virtual_gnss_node.py.

The nodes are declared to the launcher and the scenario loader by
``descriptors.py`` (entry-point group ``hyper_nav.aiding_nodes``). The paper
reproductions that use these cores are in the ``hyper_nav_repro`` package.
"""
