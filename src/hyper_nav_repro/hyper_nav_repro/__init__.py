"""hyper_nav_repro: the paper reproductions, one subpackage per seed.

The top floor of the workspace: it uses the filter (``hyper_nav_filter``),
the simulator (``hyper_nav_sim``) and the aiding cores (``hyper_nav_aiding``);
nothing imports it. Each ``seed<NNN>/reproduce.py`` is one command
(``ros2run hyper_nav_repro repro_seed<NNN>``, ``make repro-seed<NNN>``) with
its helpers beside it:

  seed000/  RL-DLAC (Table 5, Figs. 10-11): reproduce, study (navigation errors), plots
  seed001/  HWIL figures: a Monte Carlo campaign of seed001 (``mc_campaign``)
  seed002/  Table 2 / Figs. 6-8: reproduce, training_set (the L-EKF's data), train_lekf
  seed003/  Table 3 / Figs. 6-9: reproduce, aided_flight (INS/geomagnetic offline), bound (PCRB), table
  seed004/  Tables 4-5: reproduce, cases (the four cases through the fusion core)
"""
