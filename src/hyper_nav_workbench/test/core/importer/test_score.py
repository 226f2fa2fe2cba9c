"""core/importer/score.py: the truth interpolated to solution epochs. Slerp
over the truth rows the epochs fall between (``_knots``) gives the numbers
Slerp over every row gives, bit for bit (issue 41: half the rotations)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from hyper_nav_workbench.core.importer import columns, score


def _table(n=4001, rate_hz=200.0, seed=3):
    rng = np.random.default_rng(seed)
    t = 100.0 + np.arange(n) / rate_hz
    rph = np.column_stack([0.1 * np.sin(t), 0.05 * np.cos(0.7 * t), np.mod(0.3 * t + rng.normal(0, 1e-3, n),
                                                                            2 * np.pi)])
    lat = np.deg2rad(30.0) + 1e-6 * np.arange(n)
    return columns.FixTable(t, lat, np.deg2rad(114.0) + 1e-6 * np.arange(n), 20.0 + 0.01 * np.arange(n),
                            vel_enu_mps=rng.normal(0, 1, (n, 3)), rph_rad=rph)


def _all_rows(truth, t):
    """truth_at's rotations with Slerp over every truth row (the formula as it was)."""
    r, p, h = truth.rph_rad.T
    rots = Rotation.from_euler("ZYX", np.column_stack([np.pi / 2 - h, -p, r]))
    return Slerp(truth.t_s, rots)(t).as_matrix()


@pytest.mark.parametrize("case", ["on rows, 50 Hz", "between rows", "first and last row", "few epochs"])
def test_truth_at_over_the_bracketing_rows_equals_slerp_over_all_rows(case):
    tab = _table()
    t = {"on rows, 50 Hz": tab.t_s[::4], "between rows": tab.t_s[:-1:4] + 0.0013,
         "first and last row": np.array([tab.t_s[0], tab.t_s[1], tab.t_s[-2], tab.t_s[-1]]),
         "few epochs": np.array([tab.t_s[7] + 1e-4, tab.t_s[2000]])}[case]
    knots = score._knots(tab.t_s, t)
    assert knots is not None and len(knots) < len(tab.t_s)
    got = score.truth_at(tab, t)
    assert got["C"].tobytes() == _all_rows(tab, t).tobytes()
    assert np.array_equal(got["t"], t)


def test_truth_at_keeps_every_row_where_the_subset_saves_nothing_and_refuses_unordered_truth():
    tab = _table(n=400)
    t = tab.t_s[:-1] + 0.001                      # every interval holds an epoch
    assert score._knots(tab.t_s, t) is None
    assert score.truth_at(tab, t)["C"].tobytes() == _all_rows(tab, t).tobytes()
    bad = _table(n=400)
    bad.t_s[200] = bad.t_s[199]                   # a repeated stamp: Slerp refuses it, as before
    assert score._knots(bad.t_s, bad.t_s[::8]) is None
    with pytest.raises(ValueError):
        score.truth_at(bad, bad.t_s[::8])
