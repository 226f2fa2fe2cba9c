"""LinCov (core.lincov.linear) on a linear toy system: 1-D position and
velocity, velocity a random walk, position measured. Against (a) the
Kalman filter's own covariance when the filter's model is the truth's
(exact), (b) the exact covariance of the estimation error of a mismodelled
filter, computed by a vectorised Monte Carlo of the same linear system
(40 000 runs: the sampling error of a variance is sqrt(2 / 40000) = 0.7 %,
so 4 % is a 5-sigma bound), with an unmodelled constant acceleration bias
as an augmented truth state, (c) the split by group summing to the total."""
import numpy as np
import pytest

from hyper_nav_filter.core.lincov import LinCov

DT, STEPS = 0.5, 60
PHI = np.array([[1.0, DT], [0.0, 1.0]])
H = np.array([[1.0, 0.0]])


def q_rw(q):
    """Discrete Q of a velocity random walk (PSD q) over DT."""
    return q * np.array([[DT**3 / 3, DT**2 / 2], [DT**2 / 2, DT]])


def run_lincov(q_f, r_f, q_t, r_t, bias_sigma, P0_f, P0_t, outage=()):
    n, p = 2, (1 if bias_sigma > 0 else 0)
    N = n + p
    # truth: y = [e_p, e_v, b], e = xhat - x; x_v' = b + w, the filter ignores b: e_v' = -b - w
    Phi_y = np.eye(N)
    Phi_y[:2, :2] = PHI
    if p:
        Phi_y[0, 2] = -DT**2 / 2
        Phi_y[1, 2] = -DT
    Qt = np.zeros((N, N))
    Qt[:2, :2] = q_rw(q_t)
    P0_init = np.zeros((N, N))
    P0_init[:2, :2] = P0_t
    P0 = {"initial": P0_init}
    if p:
        Pb = np.zeros((N, N))
        Pb[2, 2] = bias_sigma**2
        P0["bias"] = Pb
    lc = LinCov(P0_f, ("initial", "bias", "process", "meas"), P0, n_filter=n)
    Hy = np.zeros((1, N))
    Hy[0, 0] = 1.0
    out = []
    for k in range(1, STEPS + 1):
        lc.predict(PHI, q_rw(q_f), Phi_y, {"process": Qt})
        if k not in outage:
            lc.update(H, [[r_f]], Hy, {"meas": [[r_t]]})
        out.append((lc.total[:2, :2].copy(), lc.P_f.copy(), lc.P.copy()))
    return out


def run_mc(q_f, r_f, q_t, r_t, bias_sigma, P0_f, P0_t, runs=40000, outage=(), seed=1):
    """The same filter (gains from its own covariance) on simulated truths."""
    rng = np.random.default_rng(seed)
    x = rng.multivariate_normal([0.0, 0.0], np.eye(2), runs)          # truth (any mean: errors matter)
    e0 = rng.multivariate_normal([0.0, 0.0], P0_t, runs)
    xh = x + e0
    b = rng.standard_normal(runs) * bias_sigma
    P = np.array(P0_f, float)
    Lq = np.linalg.cholesky(q_rw(q_t))
    out = []
    for k in range(1, STEPS + 1):
        w = rng.standard_normal((runs, 2)) @ Lq.T
        x = x @ PHI.T + w + np.outer(b, [DT**2 / 2, DT])
        xh = xh @ PHI.T
        P = PHI @ P @ PHI.T + q_rw(q_f)
        if k not in outage:
            z = x[:, 0] + rng.standard_normal(runs) * np.sqrt(r_t)
            S = P[0, 0] + r_f
            K = P[:, 0] / S
            xh = xh + np.outer(z - xh[:, 0], K)
            IKH = np.eye(2) - np.outer(K, H[0])
            P = IKH @ P @ IKH.T + np.outer(K, K) * r_f
        e = xh - x
        out.append(e.T @ e / runs)
    return out


def test_matched_models_give_the_filters_own_covariance():
    P0 = np.diag([4.0, 0.25])
    res = run_lincov(0.01, 1.0, 0.01, 1.0, 0.0, P0, P0, outage=range(20, 35))
    for true, P_f, _ in res:
        np.testing.assert_allclose(true, P_f, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("outage", [(), tuple(range(20, 35))])
def test_mismodelled_filter_matches_the_exact_covariance(outage):
    # the filter assumes 10x less process noise, 4x more measurement noise, a
    # tighter prior and no acceleration bias than the truth has
    args = dict(q_f=0.001, r_f=4.0, q_t=0.01, r_t=1.0, bias_sigma=0.02, P0_f=np.diag([1.0, 0.01]),
                P0_t=np.diag([4.0, 0.25]))
    lin = run_lincov(outage=outage, **args)
    mc = run_mc(outage=outage, **args)
    for k, ((true, P_f, _), emp) in enumerate(zip(lin, mc)):
        np.testing.assert_allclose(np.diag(emp), np.diag(true), rtol=0.04, err_msg=f"step {k + 1}")
        c = true[0, 1] / np.sqrt(true[0, 0] * true[1, 1])
        c_mc = emp[0, 1] / np.sqrt(emp[0, 0] * emp[1, 1])
        assert abs(c - c_mc) < 0.03, (k, c, c_mc)
    # and the filter's own covariance is not the truth (the test can tell them apart)
    true, P_f, _ = lin[-1]
    assert true[0, 0] > 1.5 * P_f[0, 0]


def test_groups_sum_to_the_total_and_each_is_the_single_source_run():
    args = dict(q_f=0.001, r_f=4.0, q_t=0.01, r_t=1.0, bias_sigma=0.02, P0_f=np.diag([1.0, 0.01]),
                P0_t=np.diag([4.0, 0.25]))
    full = run_lincov(**args)
    only_bias = run_lincov(**{**args, "q_t": 0.0, "r_t": 0.0, "P0_t": np.zeros((2, 2))})
    _, _, groups = full[-1]
    np.testing.assert_allclose(groups.sum(axis=0)[:2, :2], full[-1][0], rtol=1e-12)
    # the "bias" group of the full run is the run with the bias alone on
    np.testing.assert_allclose(groups[1][:2, :2], only_bias[-1][0], rtol=1e-10, atol=1e-14)
    # and every group is positive semi-definite
    for g in groups:
        assert np.linalg.eigvalsh(g).min() > -1e-12
