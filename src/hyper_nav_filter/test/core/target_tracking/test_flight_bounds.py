"""The bounds of ``flight_bounds`` on a linear-Gaussian toy where the Kalman
filter attains each exactly: a 1-D target (position, velocity) driven by an
unknown acceleration a (the maneuver parameter), position measured with
noise. Each bound is checked on a case where it must hold and is attained
(Monte Carlo MSE of the filter of that bound's model = the bound, within the
Monte Carlo's 95 % interval), and the random-walk PCRB is shown *not* to hold
on one fixed maneuver (the filter of its own model goes below it there)."""
import numpy as np
import pytest

from hyper_nav_filter.core.target_tracking import augmented as au
from hyper_nav_filter.core.target_tracking import flight_bounds as fb

DT, N = 1.0, 120
F1 = np.array([[1.0, DT, 0.5 * DT**2], [0.0, 1.0, DT], [0.0, 0.0, 1.0]])
F = np.repeat(F1[None], N - 1, 0)
H = np.array([[1.0, 0.0, 0.0]])
R = np.array([[25.0]])                       # 5 m radar noise
P0_KIN = np.diag([100.0, 4.0])               # hand-over: 10 m, 2 m/s
Q_A = 0.05                                   # random-walk density of a, (m/s^2)/sqrt(s)
P0 = np.diag([100.0, 4.0, 0.3**2])           # a's prior sigma 0.3 m/s^2
Q = np.diag([0.0, 0.0, Q_A**2 * DT])


def _kf(Z, x0, K, window_reset=None, diffuse=1e4):
    """A plain Kalman filter over runs (R, N) with precomputed gains K (the
    filter under test; its prediction x_{k+1|k} = F x_k)."""
    x = np.array(x0, float)
    out = np.empty((Z.shape[1], Z.shape[0], 3))
    for k in range(Z.shape[1]):
        if k > 0:
            x = x @ F1.T
        x = x + (Z[:, k] - x[:, 0])[:, None] * K[k][:, 0]
        out[k] = x
    return np.swapaxes(out, 0, 1)


def _fly(a_path, x0_true, rng, runs):
    """Truth (N, 3) driven by the acceleration path a_path (N,), radar (runs, N)."""
    x = np.empty((N, 3))
    x[0] = x0_true
    for k in range(1, N):
        x[k] = F1 @ x[k - 1]
        x[k, 2] = a_path[k]
    return x, x[None, :, 0] + np.sqrt(R[0, 0]) * rng.standard_normal((runs, N))


def _within_ci(err, bound_var, idx):
    """RMSE over runs and epochs of err[..., idx] against sqrt(mean bound var): (ratio, lo, hi)."""
    rmse, lo, hi = fb.rmse_interval(err[..., idx])
    b = np.sqrt(np.mean(bound_var[:, idx, idx]))
    return rmse / b, lo / b, hi / b


def test_kalman_bound_is_the_information_recursion():
    P, _ = fb.kalman_bound(F, P0, H, R, Q)
    # the information form J_{k+1} = (F J^-1 F^T + Q)^-1 + H^T R^-1 H, written out
    J = np.linalg.inv(np.linalg.inv(P0) + H.T @ np.linalg.inv(R) @ H)
    for k in range(1, N):
        J = np.linalg.inv(np.linalg.inv(F1 @ J @ F1.T + Q) + H.T @ np.linalg.inv(R) @ H)
    np.testing.assert_allclose(P[-1], J, rtol=1e-9, atol=1e-12)
    # and the augmented model's recursion (au._information_recursion) with its own H
    Fa = np.repeat(np.eye(9)[None], 5, 0)
    Fa[:, 3, 6] = 0.1
    Pa = au._information_recursion(Fa, np.eye(9), np.eye(3), np.eye(9) * 0.01, 9)
    np.testing.assert_allclose(fb.kalman_bound(Fa, np.eye(9), np.eye(3, 9), np.eye(3), np.eye(9) * 0.01)[0], Pa,
                               rtol=1e-9, atol=1e-12)


def test_random_walk_pcrb_is_attained_on_draws_from_its_own_model():
    """Acceleration paths drawn from the random walk (prior N(0, 0.3^2), Q_A):
    the Kalman filter of that model attains the PCRB, within the Monte Carlo's
    95 % interval, in all three states; no draw-averaged ratio below it."""
    rng = np.random.default_rng(1)
    runs = 4000
    P, K = fb.kalman_bound(F, P0, H, R, Q)
    a0 = 0.3 * rng.standard_normal(runs)
    a = a0[:, None] + np.concatenate([np.zeros((runs, 1)), np.cumsum(Q_A * np.sqrt(DT) * rng.standard_normal(
        (runs, N - 1)), axis=1)], axis=1)
    X = np.empty((runs, N, 3))
    X[:, 0] = np.stack([rng.standard_normal(runs) * 10.0, rng.standard_normal(runs) * 2.0, a0], 1)
    for k in range(1, N):
        X[:, k] = X[:, k - 1] @ F1.T
        X[:, k, 2] = a[:, k]
    Z = X[..., 0] + 5.0 * rng.standard_normal((runs, N))
    err = X - _kf(Z, np.zeros((runs, 3)), K)
    for i in range(3):
        ratio, lo, hi = _within_ci(err, P, i)
        assert lo <= 1.0 <= hi, (i, ratio, lo, hi)
        assert abs(ratio - 1.0) < 0.03, (i, ratio)


def test_random_walk_pcrb_does_not_hold_on_one_fixed_maneuver():
    """The same filter on one fixed maneuver (a = 0 for 60 s, then a step to
    0.2 m/s^2 held: one increment where the walk expects 119): its MSE is the
    bound's noise part C plus the path's own bias m m^T (fixed_path_error,
    checked by Monte Carlo), and in velocity and acceleration it is below the
    PCRB by far more than the Monte Carlo's interval; above the
    known-maneuver bound in every state."""
    rng = np.random.default_rng(2)
    runs = 3000
    a_path = np.where(np.arange(N) >= 60, 0.2, 0.0)
    x_true, Z = _fly(a_path, np.array([0.0, 30.0, 0.0]), rng, runs)
    P, K = fb.kalman_bound(F, P0, H, R, Q)
    x0 = x_true[0] + np.concatenate([rng.standard_normal((runs, 2)) * [10.0, 2.0], np.zeros((runs, 1))], 1)
    err = x_true[None] - _kf(Z, x0, K)
    drive = np.diff(x_true, axis=0) - np.einsum("ij,kj->ki", F1 - np.eye(3), x_true[:-1])   # x_{k+1} - F x_k
    C, m = fb.fixed_path_error(F, K, H, R, np.diag([100.0, 4.0, 0.0]), np.zeros(3), drive)
    mse_pred = np.diagonal(C, axis1=1, axis2=2) + m**2
    mse_mc = np.mean(err**2, axis=0)
    np.testing.assert_allclose(mse_mc.mean(0), mse_pred.mean(0), rtol=0.05)
    Pk, _ = fb.kalman_bound(F[:, :2, :2], P0_KIN, H[:, :2], R, np.zeros((2, 2)))
    for i in (1, 2):
        ratio, lo, hi = _within_ci(err, P, i)
        assert hi < 0.9, (i, ratio, lo, hi)                  # measured 0.82 (v), 0.52 (a)
    for i in (0, 1):
        ratio, lo, hi = _within_ci(err, Pk, i)
        assert lo > 1.0, (i, ratio, lo, hi)


@pytest.mark.parametrize("window", [10, 30])
def test_windowed_crb_is_attained_by_the_unbiased_filter_of_its_model(window):
    """The maneuver as unknown constants per window (no prior): the Kalman
    filter of that model (a diffuse, fresh a at each window start) is unbiased
    for every such maneuver and attains the windowed CRB on a fixed
    piecewise-constant maneuver within the Monte Carlo's 95 % interval; the
    bound grows as the windows shorten and lies above the known-maneuver
    bound; the diffuse limit is reached (1e4 vs 1e5 within 1e-4, 1e3 within 1e-3)."""
    rng = np.random.default_rng(3)
    runs = 4000
    wid = fb.window_ids(np.arange(N) * DT, window)
    a_steps = np.array([0.4, -0.3, 0.2, 0.0])[wid % 4]              # the acceleration of each step
    a_path = np.concatenate([a_steps, a_steps[-1:]])
    x_true, Z = _fly(a_path, np.array([0.0, 30.0, a_path[0]]), rng, runs)
    Pw = fb.windowed_crb(F, P0_KIN, H, R, 2, wid)
    # the filter of the windowed model, written out (diffuse reset of a at each window start)
    x = x_true[0] + np.concatenate([rng.standard_normal((runs, 2)) * [10.0, 2.0], np.zeros((runs, 1))], 1)
    Pf = np.zeros((3, 3))
    Pf[:2, :2], Pf[2, 2] = P0_KIN, 1e8
    est = np.empty((runs, N, 3))
    for k in range(N):
        if k > 0:
            if k > 1 and wid[k - 1] != wid[k - 2]:
                Pf[:2, 2] = Pf[2, :2] = 0.0
                Pf[2, 2] = 1e8
            x, Pf = x @ F1.T, F1 @ Pf @ F1.T
        S = Pf[0, 0] + R[0, 0]
        Kk = Pf[:, 0] / S
        x = x + (Z[:, k] - x[:, 0])[:, None] * Kk
        Pf = Pf - np.outer(Kk, Pf[0])
        est[:, k] = x
    np.testing.assert_allclose(np.diagonal(Pw, axis1=1, axis2=2)[5:], np.diagonal(
        fb.windowed_crb(F, P0_KIN, H, R, 2, wid, diffuse_sigma=1e5), axis1=1, axis2=2)[5:], rtol=1e-4)
    np.testing.assert_allclose(np.diagonal(Pw, axis1=1, axis2=2)[5:], np.diagonal(
        fb.windowed_crb(F, P0_KIN, H, R, 2, wid, diffuse_sigma=1e3), axis1=1, axis2=2)[5:], rtol=1e-3)
    err = x_true[None] - est
    # the kinematic states (a is the nuisance parameter of the next step)
    assert np.all(np.abs(err.mean(0)[5:, :2]) < 4.5 * err.std(0)[5:, :2] / np.sqrt(runs))     # unbiased
    for i in (0, 1):
        ratio, lo, hi = _within_ci(err, Pw, i)
        assert lo <= 1.0 <= hi, (i, ratio, lo, hi)
    Pk, _ = fb.kalman_bound(F[:, :2, :2], P0_KIN, H[:, :2], R, np.zeros((2, 2)))
    shorter = fb.windowed_crb(F, P0_KIN, H, R, 2, fb.window_ids(np.arange(N) * DT, window / 2))
    one = fb.windowed_crb(F, P0_KIN, H, R, 2, fb.window_ids(np.arange(N) * DT, np.inf))
    for i in (0, 1):
        b = [np.mean(p[:, i, i]) for p in (Pk, one, Pw, shorter)]
        assert b[0] <= b[1] * (1 + 1e-9) and b[1] < b[2] < b[3], b


def test_rmse_interval_covers_at_its_level():
    """The Student-t interval on the per-run mean squares covers the true RMSE
    about 95 % of the time (400 Monte Carlo sets of 20 runs, correlated epochs)."""
    rng = np.random.default_rng(4)
    hits = 0
    for _ in range(400):
        e = np.cumsum(rng.standard_normal((20, 200)), axis=1) / np.sqrt(np.arange(1, 201))   # var 1 at every epoch
        _, lo, hi = fb.rmse_interval(e)
        hits += lo <= 1.0 <= hi
    assert 0.91 <= hits / 400 <= 0.99, hits / 400
