"""Linear covariance analysis of a (possibly mismodelled) Kalman filter.

The augmented vector is y = [e; s]: e (n) the filter's estimation error in
its own error-state convention (estimate - truth), s (p) the truth's error
sources that are states (random constants, Gauss-Markov processes the
simulated world carries, whether or not the filter models them). Between
measurements y evolves by the truth's linearised dynamics, y+ = Phi_y y +
w_y, while the filter propagates its own covariance with its own model
(Phi_f, Q_f). At a measurement the filter forms its gain from its own
covariance, K = P_f H_f^T (H_f P_f H_f^T + R_f)^-1, and corrects with the
residual r = H_y y + v (v the truth's measurement noise, covariance R_t):

    e+ = e - K r    =>    y+ = (I - [K; 0] H_y) y - [K; 0] v.

So the true covariance of y is P_y+ = A P_y A^T + [K; 0] R_t [K; 0]^T,
A = I - [K; 0] H_y (Maybeck, Stochastic Models vol. 1, sec. 6.8, the
"truth model" error analysis of a suboptimal filter; Geller, J. Guid.
Control Dyn. 29(6), 2006, the LinCov formulation of aerospace GNC). When the
filter's model equals the truth's (y = e, Phi_y = Phi_f, Q_y = Q_f,
H_y = H_f, R_t = R_f) the recursion is the Joseph form and P_y = P_f.

Everything is linear in the independent inputs, so P_y is the sum of the
contributions of each *group* of inputs (an initial-uncertainty part, a
process-noise part, a measurement-noise part): propagating one covariance
per group with the same Phi_y and A gives the error budget by source, and
their sum is the total exactly. ``LinCov`` carries that stack.

Pure numpy; no knowledge of INS or sensors (``core.lincov.ins`` builds the
matrices from the filter's state blocks and measurement models).
"""
from __future__ import annotations

import numpy as np


class LinCov:
    """The filter's own covariance P_f (n x n) and the true covariance of
    y = [e; s] split by input group, ``P`` (G, N x N), N = n + p.

    ``groups``: ordered names; ``P0_groups``: {name: N x N} initial
    covariance of each group that has one (others start at zero)."""

    def __init__(self, P_f0: np.ndarray, groups, P0_groups: dict, n_filter: int | None = None):
        self.P_f = np.array(P_f0, float)
        self.n = len(self.P_f) if n_filter is None else int(n_filter)
        self.groups = tuple(groups)
        self.index = {g: i for i, g in enumerate(self.groups)}
        unknown = set(P0_groups) - set(self.groups)
        if unknown:
            raise ValueError(f"initial covariance for unknown groups {sorted(unknown)}")
        N = None
        for v in P0_groups.values():
            N = len(v)
        if N is None:
            raise ValueError("LinCov needs the size of y: give at least one group's initial covariance")
        self.N = N
        self.P = np.zeros((len(self.groups), N, N))
        for g, v in P0_groups.items():
            self.P[self.index[g]] = np.asarray(v, float)
        self.n_updates = 0

    @property
    def total(self) -> np.ndarray:
        """The true covariance of y (sum over the groups)."""
        return self.P.sum(axis=0)

    def predict(self, Phi_f, Q_f, Phi_y, Q_y_groups: dict | None = None) -> None:
        """One propagation step: the filter's P_f with its (Phi_f, Q_f); every
        group's covariance with the truth's Phi_y, plus the group's own
        process noise (``Q_y_groups``: {name: N x N}, discrete)."""
        P = Phi_f @ self.P_f @ Phi_f.T + Q_f
        self.P_f = 0.5 * (P + P.T)
        self.P = Phi_y @ self.P @ Phi_y.T
        for g, Q in (Q_y_groups or {}).items():
            self.P[self.index[g]] += Q

    def gain(self, H_f, R_f) -> np.ndarray:
        """The filter's own Kalman gain K = P_f H_f^T S^-1."""
        S = H_f @ self.P_f @ H_f.T + R_f
        return np.linalg.solve(0.5 * (S + S.T), H_f @ self.P_f).T

    def update(self, H_f, R_f, H_y, R_t_groups: dict) -> np.ndarray:
        """One measurement: the filter's Joseph update of P_f with its model
        (H_f, R_f) and the true covariance through A = I - [K; 0] H_y plus
        each measurement-noise group's [K; 0] R_t [K; 0]^T. Returns K."""
        H_f = np.atleast_2d(np.asarray(H_f, float))
        R_f = np.atleast_2d(np.asarray(R_f, float))
        K = self.gain(H_f, R_f)
        I_KH = np.eye(len(self.P_f)) - K @ H_f
        P = I_KH @ self.P_f @ I_KH.T + K @ R_f @ K.T
        self.P_f = 0.5 * (P + P.T)
        Kf = np.zeros((self.N, K.shape[1]))
        Kf[:self.n] = K
        A = np.eye(self.N) - Kf @ np.atleast_2d(np.asarray(H_y, float))
        self.P = A @ self.P @ A.T
        for g, R in R_t_groups.items():
            self.P[self.index[g]] += Kf @ np.atleast_2d(np.asarray(R, float)) @ Kf.T
        self.n_updates += 1
        return K
