"""Cramer-Rao bound of the three natural frequencies from one data window.

For a linear Gaussian state-space model the filter's innovations nu_k with
covariances S_k give the exact likelihood of the measurements, so the Fisher
information of the parameters theta (here the frequencies w_1..3) is

    I_ab = sum_k  d_a nu_k^T S_k^-1 d_b nu_k  +  1/2 tr(S_k^-1 d_a S_k S_k^-1 d_b S_k)

(e.g. Gupta & Mehra 1974; Kay, Fundamentals of Statistical Signal Processing I,
eq. 3.31 for the Gaussian case). The sensitivities d nu / d theta and
d S / d theta come from central differences of filter passes (``replay``) over
the window: 6 passes plus one. CRB = I^-1; its diagonal bounds the variance of
any unbiased estimator from this window. The information per measurement kind
is kept, so the report can say where it comes from (position or velocity).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_aiding.lever_arm.core.replay import replay


@dataclass
class CramerRaoBound:
    theta_radps: np.ndarray           # where the information was evaluated
    fisher: np.ndarray                # 3 x 3, (rad/s)^-2
    fisher_by_kind: dict              # kind -> 3 x 3
    n_passes: int

    @property
    def cov(self) -> np.ndarray:
        return np.linalg.pinv(self.fisher)

    @property
    def sigma_radps(self) -> np.ndarray:
        """1-sigma bound of each frequency with the other two unknown too."""
        return np.sqrt(np.abs(np.diag(self.cov)))

    @property
    def sigma_rel(self) -> np.ndarray:
        return self.sigma_radps / self.theta_radps

    @property
    def sigma_alone_rel(self) -> np.ndarray:
        """1-sigma bound of each frequency if the other two were known."""
        return 1.0 / np.sqrt(np.diag(self.fisher)) / self.theta_radps

    def principal(self):
        """Relative 1-sigma along the eigenvectors of the (relative) information,
        best-determined first: (sigmas, directions as columns)."""
        D = np.diag(self.theta_radps)
        ev, V = np.linalg.eigh(D @ self.fisher @ D)
        order = np.argsort(ev)[::-1]
        return 1.0 / np.sqrt(np.maximum(ev[order], 1e-300)), V[:, order]

    def as_dict(self) -> dict:
        s, V = self.principal()
        return {"theta_radps": self.theta_radps.tolist(), "sigma_radps": self.sigma_radps.tolist(),
                "sigma_pct": (100 * self.sigma_rel).tolist(), "sigma_alone_pct": (100 * self.sigma_alone_rel).tolist(),
                "principal_sigma_pct": (100 * s).tolist(), "principal_directions": V.T.tolist(),
                "fisher": self.fisher.tolist(),
                "fisher_diag_by_kind": {k: np.diag(v).tolist() for k, v in self.fisher_by_kind.items()},
                "n_passes": self.n_passes}


def fisher_information(window, cfg, theta_radps, rel_step: float = 1e-3) -> CramerRaoBound:
    """Fisher information of the frequencies at ``theta_radps`` from the
    window's innovations (module doc). ``rel_step``: central-difference step
    relative to each frequency (1e-3: the sensitivities are linear there,
    checked against 1e-4 in the tests)."""
    theta = np.asarray(theta_radps, float)
    base = replay(window, cfg, theta)
    d_nu, d_S = [], []
    for a in range(3):
        h = rel_step * theta[a]
        up, dn = theta.copy(), theta.copy()
        up[a] += h
        dn[a] -= h
        pu, pd = replay(window, cfg, up), replay(window, cfg, dn)
        d_nu.append({k: (pu.kinds[k].nu - pd.kinds[k].nu) / (2 * h) for k in base.kinds})
        d_S.append({k: (pu.kinds[k].S - pd.kinds[k].S) / (2 * h) for k in base.kinds})
    by_kind = {}
    for k, ki in base.kinds.items():
        S_inv = np.linalg.inv(ki.S)
        F = np.zeros((3, 3))
        for a in range(3):
            for b in range(a, 3):
                val = np.einsum("mi,mij,mj->", d_nu[a][k], S_inv, d_nu[b][k])
                val += 0.5 * np.einsum("mij,mjk,mkl,mli->", S_inv, d_S[a][k], S_inv, d_S[b][k])
                F[a, b] = F[b, a] = val
        by_kind[k] = F
    return CramerRaoBound(theta, sum(by_kind.values()), by_kind, 7)
