"""Compiled fast path of the filter's per-epoch predict (issue 15).

The readable numpy implementation (``core.frames``, ``core.system_model``,
``ErrorStateKF.linearize``) stays the reference; these numba kernels run
the same equations in one compiled call per IMU epoch (mechanization, F and
G from the frame core and the blocks' declared couplings, Phi, Q, P), with
scalar arithmetic and no per-call array churn. Why: a profile of the numpy
predict showed small-array overhead, not arithmetic, dominating (27
np.array, 24 .copy, 14 np.zeros and 10 np.eye calls per epoch, ~0.4 ms);
compiled, the same step costs a few microseconds. A test compares this path
with the reference to 1e-9 (``test_fast_path``). Kernels are cached on disk
(numba ``cache=True``): the first process compiles them (a few seconds),
later ones load them.
"""
