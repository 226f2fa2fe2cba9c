"""replay_filter's summaries and text outputs over whole arrays (issue 41)
against the per-solution formulas they replaced, on a replay of the sample
bag with both streams kept (delayed solutions and the current-time log):
the same numbers bit for bit (==, not a tolerance), so the command's files
and printed report do not change."""
import math
import pathlib

import numpy as np
import pytest

from hyper_nav_filter.core import fusion
from hyper_nav_filter.core.attitude import C_b_n_to_euler
from hyper_nav_filter.offline_arrays import run_offline_arrays
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_workbench import replay_filter
from hyper_nav_workbench.core import array_io, scoring
from hyper_nav_workbench.core.bag_arrays import _gather, read_arrays
from hyper_nav_workbench.graph import bag_scenario

BAG = pathlib.Path(__file__).resolve().parents[3] / "bags" / "sample_short"


@pytest.fixture(scope="module")
def bag():
    return load_scenario(bag_scenario(BAG)), read_arrays(BAG)


@pytest.fixture
def run(bag):
    """A fresh replay per test: the reference formulas read ``.state`` and ``.P``, which fills the lazy
    solutions' caches, and the array forms must meet them unread."""
    sc, arrays = bag
    sols, eng, _ = run_offline_arrays(list(arrays.topics.values()), sc.filter_config(), sc.filter_initial_state(),
                                      sc.filter_sources(), final=True, keep_current=True)
    truth = array_io.states_from_topic(arrays.topics["/truth/state"])
    return sc, sols, list(eng.current_log), truth


# ---- the per-solution formulas as they were (the reference) -------------------------------
def _sigma_blocks_loop(sols, layout):
    d = np.array([np.sqrt(np.maximum(np.diag(s.P), 0.0)) for s in sols])
    return {name: d[:, layout.sl(name)] for name in layout.names if layout.sl(name).stop - layout.sl(name).start == 3}


def _stream_summary_loop(sols, truth_states, layout, skip_s):
    sols = [x for x in sols if x.t_s >= skip_s]
    nav = {"t": np.array([s.t_s for s in sols]), "lat": np.array([s.state.lat_rad for s in sols]),
           "lon": np.array([s.state.lon_rad for s in sols]), "alt": np.array([s.state.alt_m for s in sols]),
           "vel": np.array([s.state.vel_enu_mps for s in sols]).reshape(-1, 3),
           "C": np.array([s.state.C_b_n for s in sols]).reshape(-1, 3, 3)}
    err, rows = scoring.errors(nav, truth_states, index=True)
    p, v = layout.sl("pos"), layout.sl("vel")
    Ps = [sols[i].P for i in rows.tolist()]
    ep, ev = err["pos_enu_m"], err["vel_enu_mps"]
    nees_p = np.array([e @ np.linalg.solve(P[p, p], e) for P, e in zip(Ps, ep)])
    nees_v = np.array([e @ np.linalg.solve(P[v, v], e) for P, e in zip(Ps, ev)])
    return {"epochs": len(err["t"]), "pos_rms_3d_m": float(np.sqrt(np.mean(np.sum(ep ** 2, axis=1)))),
            "vel_rms_3d_mps": float(np.sqrt(np.mean(np.sum(ev ** 2, axis=1)))),
            "nees_pos_mean": float(np.mean(nees_p)), "nees_vel_mean": float(np.mean(nees_v))}


# ---- tests --------------------------------------------------------------------------------
def test_euler_rows_is_the_closed_form_per_matrix_bit_for_bit(run):
    _, sols, _, _ = run
    C = scoring.states_from_solutions(sols)["C"]
    rng = np.random.default_rng(41)
    from scipy.spatial.transform import Rotation
    rand = Rotation.random(20000, random_state=rng).as_matrix()
    lock = Rotation.from_euler("ZYX", [[0.3, math.pi / 2, 0.2], [1.0, -math.pi / 2, -0.4]]).as_matrix()
    lock[:, 2, 1:] = 0.0                         # c_y exactly 0: the gimbal-lock branch
    for stack in (C, rand, lock):
        ref = np.array([C_b_n_to_euler(m) for m in stack])
        got = array_io.euler_rows(stack)
        assert got.shape == ref.shape and np.array_equal(got, ref)
    assert array_io.euler_rows(np.zeros((0, 3, 3))).shape == (0, 3)


def test_sigma_blocks_and_covariance_blocks_equal_the_per_solution_formulas(run):
    sc, sols, current, _ = run
    layout = sc.filter_config().layout
    assert len(sols) > 900 and len(current) >= len(sols)
    for stream in (sols, current):
        assert fusion._lazy_source(stream) is not None
        new = replay_filter.sigma_blocks(stream, layout)     # before the loop below reads .P of each
        Ps = fusion.solution_covariances(stream)
        pos, vel = replay_filter.cov_blocks(Ps, layout.sl("pos"), layout.sl("vel"))
        ref = _sigma_blocks_loop(stream, layout)
        assert new.keys() == ref.keys() and {"pos", "vel", "att", "bg", "ba"} <= set(ref)
        for k in ref:
            assert np.array_equal(new[k], ref[k]), k
        assert np.array_equal(pos, np.array([s.P[layout.sl("pos"), layout.sl("pos")] for s in stream]))
        assert np.array_equal(vel, np.array([s.P[layout.sl("vel"), layout.sl("vel")] for s in stream]))
    empty = replay_filter.cov_blocks([], layout.sl("pos"))
    assert empty[0].shape == (0, 3, 3)


def test_stream_summary_equals_the_per_solution_summary(run):
    sc, sols, current, truth = run
    layout, skip = sc.filter_config().layout, 2.0
    got = [replay_filter.stream_summary(s, truth, layout, skip) for s in (sols, current)]
    ref = [_stream_summary_loop(s, truth, layout, skip) for s in (sols, current)]
    assert got == ref                           # every figure ==, as the printed line shows them
    assert got[1]["epochs"] >= got[0]["epochs"] > 500 and 0.0 < got[0]["nees_pos_mean"] < 50.0


def test_errors_without_attitude_are_the_same_position_and_velocity_errors(run):
    _, sols, _, truth = run
    nav = scoring.states_from_solutions(sols)
    a, ra = scoring.errors(nav, truth, index=True)
    b, rb = scoring.errors(nav, truth, index=True, attitude=False)
    assert np.array_equal(ra, rb) and "att_enu_deg" not in b and len(b["t"]) > 900
    for k in ("t", "pos_enu_m", "vel_enu_mps"):
        assert np.array_equal(a[k], b[k]), k


def test_byte_gather_equals_the_index_gather():
    rng = np.random.default_rng(7)
    buf = rng.integers(0, 256, 5000).astype(np.uint8)
    for offs in (np.arange(0, 4000, 37), np.sort(rng.choice(4900, 300, replace=False)), np.array([5]),
                 np.zeros(0, np.int64)):
        offs = offs.astype(np.int64)
        ref = buf[offs[:, None] + np.arange(40)]
        assert np.array_equal(_gather(buf, offs, 40), ref)
        ro = buf.copy()
        ro.setflags(write=False)
        assert np.array_equal(_gather(ro, offs, 40), ref)
    with pytest.raises(IndexError):             # past the end: raised as the index gather raises
        _gather(buf, np.array([4990], np.int64), 40)


def test_byte_scatter_equals_the_index_assignment():
    from hyper_nav_workbench.core.bag_arrays import _scatter
    rng = np.random.default_rng(8)
    rows = rng.integers(0, 256, (120, 31)).astype(np.uint8)
    for offs in (np.arange(0, 120 * 40, 40), np.sort(rng.choice(4000, 120, replace=False)) // 31 * 33):
        offs = offs.astype(np.int64)
        ref, got = np.zeros(5000, np.uint8), np.zeros(5000, np.uint8)
        ref[offs[:, None] + np.arange(31)] = rows
        _scatter(got, offs, rows)
        assert np.array_equal(got, ref)
    with pytest.raises(IndexError):
        _scatter(np.zeros(100, np.uint8), np.array([80], np.int64), rows[:1])
