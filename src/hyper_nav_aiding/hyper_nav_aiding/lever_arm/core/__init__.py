"""RL-DLAC: re-estimation of the elastic lever-arm natural frequencies (seed 000,
Yang et al. 2022, section III), triggered by position residuals.

Modules (one algorithm each): ``trigger`` (residual threshold with hysteresis and
cool-down), ``window`` (the IMU/GNSS data window and its ring buffer), ``replay``
(one pass of the core filter over a window with candidate frequencies: the unit
of cost), ``env`` (Gymnasium environment, Table 1), ``ddpg`` (the agent, Table 3,
flax + optax), ``identifiers`` (CMA-ES, Nelder-Mead, maximum likelihood on the
innovations), ``crb`` (Cramer-Rao bound from one window), ``reestimate`` (one
re-estimation job as the node's worker runs it).
"""
