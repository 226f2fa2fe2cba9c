"""The walk_0827 recording (../shared/real-data, read at test time) through
import_data (IMU mounting, alignment on the data) and the tightly coupled
filter, first 20 s after the alignment: horizontal RMS against the
RTK-fixed epochs (datum offset removed, repro_walk) under a bound set from the
full run (make repro-walk: 0.58 m over 296 epochs), and below the receiver's
own single-point solution on the same epochs."""
import pathlib

import pytest

from hyper_nav_repro.walk import reproduce as repro_walk
from hyper_nav_workbench.spp import default_data_dir

DATA = pathlib.Path(default_data_dir()) / "walk_0827"
pytestmark = pytest.mark.skipif(not (DATA / "imu_1730_sf.csv").exists(), reason="shared walk_0827 data not found")


@pytest.mark.slow          # ~20 s: SPP of the first 35 s of the log, the import, the TC and LC runs
def test_walk_segment_tightly_coupled_beats_single_point(tmp_path):
    res = repro_walk.reproduce(tmp_path, end_s=20.0, outages=False, plots=False)
    a = res["alignment"]
    assert a["method"] == "gnss_velocity" and a["static"]
    tc, spp = res["runs"]["tc"], res["runs"]["spp"]
    assert tc["n"] >= 75
    assert tc["horizontal_rms_m"] < 1.0             # full run 0.58 m; this segment 0.38 m (SPP 1.02 m)
    assert tc["horizontal_rms_m"] < spp["horizontal_rms_m"]
    assert tc["counters"]["imu_accepted"] > 2900


def test_mean_sigma_of_correlated_series_matches_ar1_theory():
    """The datum offset's 1-sigma (repro_walk.mean_sigma) on a seeded AR(1)
    series, rho = 0.9: sigma of the mean = sigma / sqrt(n) sqrt((1 + rho) /
    (1 - rho)) (4.36x the white value); white noise: sigma / sqrt(n).
    Tolerance 25 % (the estimate's own spread at n = 20000)."""
    import numpy as np
    from hyper_nav_repro.walk.reproduce import mean_sigma
    rng = np.random.default_rng(7)
    n, rho = 20000, 0.9
    w = rng.standard_normal((n, 2))
    x = np.empty(n)
    x[0] = w[0, 0]
    for k in range(1, n):
        x[k] = rho * x[k - 1] + np.sqrt(1 - rho ** 2) * w[k, 0]
    s = mean_sigma(np.column_stack([x, w[:, 1]]))
    assert s[0] == pytest.approx(np.sqrt((1 + rho) / (1 - rho) / n), rel=0.25)
    assert s[1] == pytest.approx(1.0 / np.sqrt(n), rel=0.25)


@pytest.fixture(scope="module")
def whole_walk(tmp_path_factory):
    """The whole walk (no outages, no plots), once for this module's tests."""
    return repro_walk.reproduce(tmp_path_factory.mktemp("walk"), outages=False, plots=False)


@pytest.mark.slow          # ~40 s: the whole walk, the single-point fixes and four filter runs
def test_whole_walk_with_range_bias_states_is_consistent_and_beats_single_point(whole_walk):
    """Issue 21's NEES goal on the real recording: the tightly coupled filter
    with per-satellite range-bias states (repro_walk.RANGE_BIAS_VARIANT) has
    its mean position NEES against the RTK-fixed epochs inside the 95 % band
    of the mean over the run (measured 2.77 in [2.73, 3.29], 294 of 296 epochs
    inside the single-epoch interval) and stays below the single-point
    solution (measured H RMS 0.662 / 95 % 0.937 / V RMS 1.742 m against
    1.146 / 2.056 / 2.694 m); the import file's own filter (no range-bias
    states) is the more accurate and the optimistic one (0.599 m, NEES 4.79)."""
    from scipy.stats import chi2
    res = whole_walk
    rb, tc, spp = res["runs"]["tc_rb"], res["runs"]["tc"], res["runs"]["spp"]
    n = rb["n"]
    assert n >= 290
    lo, hi = chi2.ppf(0.025, 3 * n) / n, chi2.ppf(0.975, 3 * n) / n
    assert lo <= rb["nees_mean"] <= hi, (rb["nees_mean"], lo, hi)
    assert rb["nees_epochs_inside_95"] >= 0.95 * n
    for k in ("horizontal_rms_m", "horizontal_p95_m", "vertical_rms_m"):
        assert rb[k] < spp[k], k
    assert tc["nees_mean"] > hi and tc["horizontal_rms_m"] < rb["horizontal_rms_m"]


@pytest.mark.slow          # ~20 s: SPP of the first 35 s, the import, four filter runs
def test_walk_segment_default_tightly_coupled_filter_is_not_optimistic(tmp_path):
    """Issue 37 item 5 on the first 20 s after the alignment: the import
    file's filter with the defaults (range-bias states rb32, 2.2 m / 1500 s)
    is below single point horizontally and not optimistic. Measured: H RMS
    0.500 m (single point 1.024, white range errors 0.377), mean NEES 0.75
    (band of the mean over 77 epochs 2.48-3.57: below it; white 0.50), all 77
    epochs below the single-epoch 97.5 % bound (white: 77)."""
    from scipy.stats import chi2
    res = repro_walk.reproduce(tmp_path, end_s=20.0, outages=False, plots=False)
    d, spp = res["runs"]["tc_default"], res["runs"]["spp"]
    n = d["n"]
    assert n >= 75
    assert d["horizontal_rms_m"] < spp["horizontal_rms_m"] and d["horizontal_rms_m"] < 0.75
    assert d["nees_mean"] < chi2.ppf(0.975, 3 * n) / n
    assert d["nees_epochs_below_upper95"] == n


@pytest.mark.slow          # shares the whole-walk run above
def test_whole_walk_default_tightly_coupled_filter_accuracy_and_nees(whole_walk):
    """Issue 37 item 5 on the whole walk (296 RTK-fixed epochs): the import
    file's filter with the defaults (range-bias states) against the same
    filter with white range errors (``tc``, the import file's filter before
    item 5). Measured: H RMS 0.529 m (white 0.599; goal: no worse than 0.60),
    H 95 % 0.739 m (0.769), mean NEES 0.94 (white 4.79; band of the mean
    2.73-3.29): below the band, not above it: the reference's datum is the mean
    single-point error, which takes away the errors common to the whole walk
    (the slowly varying range errors among them) that the filter's covariance
    rightly holds (seed 004, where the truth is known: in band). Vertical
    RMS 2.21 m (white 0.75), a near-constant 2.0 m against that datum (mean
    error in walk.json). Tolerances: H RMS <= 0.60 m; NEES below the band's
    upper end; >= 95 % of epochs inside the single-epoch interval."""
    from scipy.stats import chi2
    d, tc, spp = whole_walk["runs"]["tc_default"], whole_walk["runs"]["tc"], whole_walk["runs"]["spp"]
    n = d["n"]
    assert n >= 290
    assert d["horizontal_rms_m"] <= 0.60 and d["horizontal_rms_m"] <= tc["horizontal_rms_m"]
    assert d["horizontal_p95_m"] < spp["horizontal_p95_m"]
    assert d["nees_mean"] < chi2.ppf(0.975, 3 * n) / n < tc["nees_mean"]
    assert d["nees_epochs_inside_95"] >= 0.95 * n
