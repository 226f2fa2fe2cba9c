"""tc_consistency (hyper_nav_repro/seed004/tc_consistency.py): the ANEES band and a
short flight of seed 004 case (a) in the realistic world, where the
range-bias states make the position covariance honest (measured on the
first 60 s, seed 1: mean NEES 65.5 before, 2.94 after; the full flight and
three seeds: docs/gnss_real_data.md)."""
import numpy as np
import pytest

from hyper_nav_repro.seed004 import tc_consistency as tc


def test_anees_band_is_the_chi_square_band_over_runs():
    lo, hi = tc.anees_band(3)                       # chi2(9) 2.5 % / 97.5 % quantiles 2.700 / 19.023, over 3 runs
    assert lo == pytest.approx(2.700 / 3, abs=1e-3) and hi == pytest.approx(19.023 / 3, abs=1e-3)
    assert tc.anees_band(1) == pytest.approx((0.2158, 9.3484), abs=1e-4)


def test_unknown_configuration_or_variant_is_refused_with_the_known_names(capsys):
    for args, named in ((["--configs", "befor"], "'befor' (known: before, after, defaults)"),
                        (["--variants", "a,b"], "'b' (known: a, loss_120s)")):
        with pytest.raises(SystemExit) as exc:
            tc.main(args)
        assert exc.value.code == 2 and named in capsys.readouterr().err


@pytest.mark.slow
def test_range_bias_states_bring_the_nees_into_the_band_on_a_short_flight():
    res = tc.run([1], variants={"a": ("a", None)}, duration_s=40.0, log=lambda *a: None)
    s = tc.summarize(res)
    before, after = s["before"]["a"], s["after"]["a"]
    lo, hi = after["anees_band_95"]
    assert before["anees_flight_mean"] > 5 * hi                   # white-noise weighting: overconfident
    assert lo < after["anees_flight_mean"] < hi and after["share_of_epochs_in_band"] > 0.9
    assert np.isfinite(after["pos_rms_h_m"]) and after["pos_rms_h_m"] < 3.0


@pytest.mark.slow          # ~30-50 s: three 60 s flights, each flown twice
def test_scenario_defaults_are_consistent_on_three_seeds():
    """Issue 37 item 5: seed 004 case (a) in the realistic world with the
    scenario as it is (nothing set: the filter's default range-bias states)
    against the filter before item 5 (``BEFORE``: white range errors,
    sigma_scale 8), seeds 1-3, first 60 s. Measured: defaults ANEES flight
    mean 2.90 (band 0.90-6.34), 100 % of epochs in band, per seed 2.94 / 2.69 /
    3.07, H RMS 1.01 m; before 131.6 (per seed 65.5 / 103.0 / 226.3), H RMS
    3.11 m. Tolerances: the band itself, >= 90 % of epochs inside it, every
    seed's mean NEES within the single-run band of its time mean (0.2-9.3),
    H RMS below the white filter's."""
    res = tc.run([1, 2, 3], configs={"before": tc.BEFORE, "defaults": {}}, variants={"a": ("a", None)},
                 duration_s=60.0, log=lambda *a: None)
    s = tc.summarize(res)
    d, b = s["defaults"]["a"], s["before"]["a"]
    lo, hi = d["anees_band_95"]
    assert lo < d["anees_flight_mean"] < hi and d["share_of_epochs_in_band"] >= 0.9, d
    lo1, hi1 = tc.anees_band(1)
    assert all(lo1 < x < hi1 for x in d["mean_nees_per_seed"]), d["mean_nees_per_seed"]
    assert b["anees_flight_mean"] > 5 * hi
    assert d["pos_rms_h_m"] < b["pos_rms_h_m"]
