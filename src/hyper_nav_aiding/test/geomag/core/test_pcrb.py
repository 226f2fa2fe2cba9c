"""The PCRB machinery: the incremental batch form against the Kalman
recursion (white noise) and against a brute-force joint-Gaussian
conditioning (correlated map error)."""
import numpy as np

from hyper_nav_aiding.geomag.core import pcrb


def _random_system(rng, n=4, N=8):
    Phi = np.array([np.eye(n)] + [np.eye(n) + 0.1 * rng.normal(size=(n, n)) for _ in range(N - 1)])
    Q = np.array([np.zeros((n, n))] + [np.diag(rng.uniform(0.01, 0.1, n)) for _ in range(N - 1)])
    P0 = np.diag(rng.uniform(1.0, 4.0, n))
    rows = [None] + [pcrb.Rows(rng.normal(size=(2, n)), rng.uniform(0.1, 0.5, 2), np.array([1.0, 0.0]))
                     for _ in range(N - 1)]
    return P0, pcrb.ErrorTransitions(np.arange(N, dtype=float), Phi, Q), rows


def test_batch_bound_equals_the_kalman_recursion_for_white_noise():
    rng = np.random.default_rng(0)
    P0, tr, rows = _random_system(rng)
    white = [None if r is None else pcrb.Rows(r.H, r.r) for r in rows]
    a = pcrb.linear_gaussian_bound(P0, tr, white, None)
    b = pcrb.riccati_bound(P0, tr, white)
    assert np.allclose(a, b, rtol=1e-9, atol=1e-12)
    # a white map-error channel is white measurement noise added to the coloured rows
    sig = 0.7
    c = pcrb.linear_gaussian_bound(P0, tr, rows, pcrb.white_map_error_cov(sig))
    d = pcrb.riccati_bound(P0, tr, [None if r is None else pcrb.Rows(r.H, r.r + np.array([sig**2, 0.0]))
                                    for r in rows])
    assert np.allclose(c, d, rtol=1e-9, atol=1e-12)


def test_batch_bound_equals_brute_force_conditioning_with_correlated_map_error():
    rng = np.random.default_rng(1)
    P0, tr, rows = _random_system(rng, n=3, N=6)
    pos = np.cumsum(rng.uniform(500.0, 2000.0, (6, 3)), axis=0)
    cov_fn = pcrb.gaussian_map_error_cov(pos, 2.0, 3000.0)
    got = pcrb.linear_gaussian_bound(P0, tr, rows, cov_fn)
    # brute force: stack x_0..x_N-1 and all measurements, condition jointly
    n, N = 3, 6
    Pall = np.zeros((n * N, n * N))
    Pk, blocks = P0.copy(), [P0.copy()]
    for k in range(1, N):
        Pk = tr.Phi[k] @ Pk @ tr.Phi[k].T + tr.Q[k]
        blocks.append(Pk.copy())
    for i in range(N):
        Pall[i * n:(i + 1) * n, i * n:(i + 1) * n] = blocks[i]
        for j in range(i + 1, N):
            F = np.eye(n)
            for k in range(i + 1, j + 1):
                F = tr.Phi[k] @ F
            Pall[j * n:(j + 1) * n, i * n:(i + 1) * n] = F @ blocks[i]
            Pall[i * n:(i + 1) * n, j * n:(j + 1) * n] = (F @ blocks[i]).T
    for k in range(1, N):
        Hs, eps, R = [], [], []
        for j in range(1, k + 1):
            for b in range(2):
                h = np.zeros(n * N)
                h[j * n:(j + 1) * n] = rows[j].H[b]
                Hs.append(h)
                eps.append((j, rows[j].c[b]))
                R.append(rows[j].r[b])
        Hs = np.array(Hs)
        C = np.array([[ci * cj * cov_fn(np.array([i]), j)[0] for (j, cj) in eps] for (i, ci) in eps])
        S = Hs @ Pall @ Hs.T + C + np.diag(R)
        X = Pall[k * n:(k + 1) * n] @ Hs.T
        want = blocks[k] - X @ np.linalg.solve(S, X.T)
        assert np.allclose(got[k], want, rtol=1e-8, atol=1e-10), k


def test_horizontal_bound_projects_on_the_gradient():
    P = np.zeros((1, 3, 3))
    P[0, :2, :2] = [[400.0, 0.0], [0.0, 100.0]]
    hb = pcrb.horizontal_bound([0.0], P, slice(0, 3), np.array([[0.0, 5.0]]))     # gradient north
    assert np.isclose(hb.sigma_along_m[0], 10.0) and np.isclose(hb.sigma_across_m[0], 20.0)
    s = hb.summary()
    assert np.isclose(s["n_mean_abs_m"], 10.0 * np.sqrt(2.0 / np.pi))
