"""hyper_nav_aiding: navigation aiding for hyper-nav.

Layout (same core/wrapper split as the other packages):
  core/   pure numpy/scipy algorithms, no rclpy:
          geomagnetic matching (MAGCOM, ICCP, SIMAN; seed 003), virtual GNSS
          pseudoranges under lock loss (seed 004), DDPG re-estimation of the
          elastic lever-arm natural frequencies (seed 000)
  nodes/  thin rclpy nodes publishing aiding measurements to the fusion node

The algorithms and nodes land with their issues; this package currently
holds only its structure (issue #2 asks for no more).
"""
