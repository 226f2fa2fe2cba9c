"""hyper_nav_workbench: what a user works the system with (it simulates nothing itself).

The graph launcher and load harness (:mod:`.graph`, :mod:`.load_harness`), the recorder / player / monitor nodes,
bag I/O (:mod:`.core.bag`, :mod:`.core.bag_arrays`), real-data import (:mod:`.import_data`, :mod:`.core.importer`),
single-point positioning on a user's receiver files (:mod:`.spp`), evaluation and report (:mod:`.report`,
:mod:`.core.scoring`, :mod:`.core.run_check`, :mod:`.replay_filter`), Monte Carlo (:mod:`.mc_campaign`,
:mod:`.core.montecarlo`), the live view (Foxglove) and the pytest fixtures for users' own ROS tests
(:mod:`.pytest_plugin`).
"""
