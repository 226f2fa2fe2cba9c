"""The one weighted least squares of the GNSS package (positioning/least_squares.py): the step against
numpy's lstsq of the whitened system, the clock columns of 1, 2 and 3 systems (per epoch and batched),
a singular geometry, and the simulated receiver's PVT and single-point positioning solving one shared
noise-free epoch to the same position."""
from __future__ import annotations

import importlib.util
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_gnss.corrections.combinations import parse_plan
from hyper_nav_gnss.corrections.receiver_model import ReceiverModel
from hyper_nav_gnss.formats import rinex_nav
from hyper_nav_gnss.observations import EphemerisStore, RawGnssEpoch
from hyper_nav_gnss.orbits import ephemeris as ep
from hyper_nav_gnss.orbits.constellation import visible_satellites
from hyper_nav_gnss.positioning import least_squares as lsq
from hyper_nav_gnss.positioning import spp
from hyper_nav_gnss.positioning.pvt import solve_pvt

_spec = importlib.util.spec_from_file_location("gnss_test_data", Path(__file__).parents[1] / "_data.py")
data = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(data)


def _problem(n=9, m=5, seed=1):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, m)), rng.normal(size=n) * 3.0, rng.uniform(0.05, 4.0, size=n)


def test_step_equals_lstsq_of_the_whitened_system():
    """dx = (H^T W H)^-1 H^T W v is the least-squares solution of sqrt(W) H dx = sqrt(W) v (numpy lstsq,
    an SVD: an independent route) to 1e-12; N, the covariance N^-1 and the residuals as written."""
    H, v, w = _problem()
    dx, N = lsq.solve_step(H, v, w)
    s = np.sqrt(w)
    ref = np.linalg.lstsq(H * s[:, None], v * s, rcond=None)[0]
    np.testing.assert_allclose(dx, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(N, H.T @ np.diag(w) @ H, rtol=1e-13, atol=0)
    np.testing.assert_allclose(lsq.covariance(H, w), np.linalg.inv(H.T @ np.diag(w) @ H), rtol=1e-12, atol=1e-15)
    x, P, r = lsq.solve_linear(H, v, w)
    np.testing.assert_allclose(x, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(P, lsq.covariance(H, w), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(r, v - H @ ref, rtol=0, atol=1e-12)
    assert np.max(np.abs(H.T @ (w * r))) < 1e-11                 # the residuals are W-orthogonal to H
    # unit weights: ordinary least squares
    np.testing.assert_allclose(lsq.solve_step(H, v, np.ones_like(w))[0], np.linalg.lstsq(H, v, rcond=None)[0],
                               rtol=0, atol=1e-12)


def test_weights_pull_the_solution_to_the_precise_measurements():
    """Closed form: one unknown, the weighted mean sum(w y) / sum(w), variance 1 / sum(w)."""
    y, sig = np.array([10.0, 12.0, 11.0]), np.array([1.0, 2.0, 0.5])
    w = 1 / sig ** 2
    x, P, r = lsq.solve_linear(np.ones((3, 1)), y, w)
    assert x[0] == pytest.approx(np.sum(w * y) / np.sum(w), abs=1e-12)
    assert P[0, 0] == pytest.approx(1 / np.sum(w), abs=1e-15)
    np.testing.assert_allclose(r, y - x[0], atol=1e-12)


def test_batched_normal_equations_equal_the_per_epoch_ones():
    """Leading epoch dimension (SPP's batch): each epoch's (N, H^T W v) as the 2-D call gives, to 1e-12."""
    probs = [_problem(seed=s) for s in range(4)]
    H = np.stack([p[0] for p in probs])
    v = np.stack([p[1] for p in probs])
    w = np.stack([p[2] for p in probs])
    N, rhs = lsq.normal_equations(H, v, w)
    for e, (He, ve, we) in enumerate(probs):
        Ne, re = lsq.normal_equations(He, ve, we)
        np.testing.assert_allclose(N[e], Ne, rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(rhs[e], re, rtol=1e-13, atol=1e-12)


def test_clock_columns_for_one_two_and_three_systems():
    rows = ["G", "E", "G", "C", "E", "C", "G"]
    np.testing.assert_array_equal(lsq.clock_columns(["G"] * 4, ["G"]), np.ones((4, 1)))
    np.testing.assert_array_equal(lsq.clock_columns(["G", "C", "C", "G"], ["G", "C"]),
                                  [[1, 0], [1, 1], [1, 1], [1, 0]])
    np.testing.assert_array_equal(lsq.clock_columns(rows, ["G", "E", "C"]),
                                  [[1, 0, 0], [1, 1, 0], [1, 0, 0], [1, 0, 1], [1, 1, 0], [1, 0, 1], [1, 0, 0]])
    # the reference is the first of the list, whichever system that is
    np.testing.assert_array_equal(lsq.clock_columns(["G", "C"], ["C", "G"]), [[1, 1], [1, 0]])
    # batched from slots: epochs x satellites, a padded row (slot -1) only on the reference column
    slots = np.array([[0, 1, 2, -1], [0, 0, 1, 1]])
    cols = lsq.clock_columns_from_slots(slots, 3)
    assert cols.shape == (2, 4, 3)
    np.testing.assert_array_equal(cols[0], [[1, 0, 0], [1, 1, 0], [1, 0, 1], [1, 0, 0]])
    np.testing.assert_array_equal(cols[1], [[1, 0, 0], [1, 0, 0], [1, 1, 0], [1, 1, 0]])


def test_singular_geometry_gives_none():
    """A clock column without rows (a system listed but not observed) and a rank-deficient line-of-sight
    block: None from the step, the covariance and the linear solve, never an exception."""
    u = np.array([[0.3, 0.4, 0.866], [-0.5, 0.1, 0.86], [0.2, -0.6, 0.77], [0.7, 0.2, 0.68], [-0.1, -0.3, 0.95]])
    H = np.hstack([u, lsq.clock_columns(["G"] * 5, ["G", "C"])])     # the C column is all zero
    v, w = np.ones(5), np.ones(5)
    assert lsq.solve_step(H, v, w) is None
    assert lsq.covariance(H, w) is None
    assert lsq.solve_linear(H, v, w) is None
    H2 = np.hstack([np.tile(u[:1], (5, 1)), np.ones((5, 1))])          # every satellite in one direction
    assert lsq.solve_step(H2, v, w) is None and lsq.covariance(H2, w) is None


T0 = ep.calendar_to_system_s("G", 2023, 1, 1, 1, 0, 0)
LAT, LON = np.deg2rad(26.5), np.deg2rad(119.0)
R0 = earth.geodetic_to_ecef(LAT, LON, 40.0)


@pytest.mark.parametrize("systems", [("G",), ("G", "C")])
def test_pvt_and_spp_solve_a_shared_epoch_to_the_same_position(systems):
    """One noise-free epoch (the simulator's observables: receiver clock 3 km, no ionosphere or
    troposphere, satellites above 10 deg), GPS L1 C/A and BeiDou B1I, solved by the simulated receiver's
    PVT (pvt.solve_pvt, its own sigmas) and by single-point positioning (spp.solve_epoch on the same
    pseudoranges as a RawGnssEpoch, its error model's weights, no RAIM exclusion), both iterated to
    convergence: the same position and clock to 1e-4 m, the PVT at the truth to 1e-5 m, SPP to 1e-4 m.

    Not to 1e-6 m: the two observation models differ outside the least squares. SPP rotates the
    satellite for the Sagnac effect by the light time of the range to the un-rotated satellite
    (receiver_model.corrected_at), the PVT by the exact one from the pseudorange; measured at the
    truth on this epoch: 1e-7 s of light time, 2e-5..2e-4 m of satellite position, residuals up to
    4.5e-5 m (SPP) against 4e-6 m (PVT); fixes 5.3e-5 m (GPS) and 5.9e-5 m (GPS + BeiDou) apart.
    Through one weighted least squares the same inputs give the same numbers (the module's tests above)."""
    from hyper_nav_sim.core.gnss import observables as ob
    nav, _ = rinex_nav.read_rinex3_nav(data.real_file(data.RINEX3))
    cur = [ep.select_ephemeris(nav, s, ep.system_time_s(s[0], T0)) for s in sorted({e.sat_id for e in nav})]
    ephs = [e for e in visible_satellites([e for e in cur if e is not None], R0, T0, 12.0).ephs
            if e.system in systems]
    o = ob.compute_observables(ephs, T0, R0, np.zeros(3), rx_clk_bias_m=3000.0, iono=None, tropo=False)
    pvt = solve_pvt(ephs, o.t_tag_s, o.pseudorange_m, o.pr_sigma_m, tol_m=1e-9, max_iter=20)
    n = len(ephs)
    raw = RawGnssEpoch(t_s=0.0, t_rx_gpst_s=float(o.t_tag_s), system=tuple(e.system for e in ephs),
                       prn=np.array([e.prn for e in ephs], int), pseudorange_m=np.asarray(o.pseudorange_m, float),
                       pseudorange_sigma_m=np.asarray(o.pr_sigma_m, float), rate_mps=np.zeros(n),
                       rate_sigma_mps=np.ones(n), locked=np.ones(n, bool),
                       signal=tuple("1C" if e.system == "G" else "2I" for e in ephs), cn0_dbhz=np.full(n, 45.0))
    cfg = spp.SppConfig(ReceiverModel(parse_plan({"G": ["1C"], "C": ["2I"]}), klobuchar=None, troposphere=False),
                          warm_tol_m=0.0, tol_m=1e-9)
    c = Counter()
    sol = spp.solve_epoch(raw, EphemerisStore(ephs), cfg, counters=c)
    assert sol.status == "ok" and sol.n_used == n, (sol.status, c)
    assert np.linalg.norm(pvt.r_e_m - R0) < 1e-5 and np.linalg.norm(sol.pos_ecef_m - R0) < 1e-4
    assert np.linalg.norm(pvt.r_e_m - sol.pos_ecef_m) < 1e-4
    assert abs(pvt.clk_bias_m - sol.clock_bias_m) < 1e-4
    assert pvt.isb_m.keys() == sol.isb_m.keys()
