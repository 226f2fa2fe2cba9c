"""The geomag node's magnetometer-sample checks (core/mag_input.py), shared
with its Monte Carlo feed: NaN / inf / non-positive magnitudes and stamps
not after the last accepted one are rejected and named; nothing else."""
import math

from hyper_nav_aiding.geomag.core.mag_input import MagInputCheck
from hyper_nav_aiding.geomag.core.matching import MagSample


def test_bad_and_out_of_order_samples_are_named_and_good_ones_pass():
    c = MagInputCheck()
    assert c.reject(MagSample(1.0, 50000.0)) is None
    assert c.reject(MagSample(2.0, math.nan)) == "rejected_mag_nan"
    assert c.reject(MagSample(math.inf, 50000.0)) == "rejected_mag_nan"
    assert c.reject(MagSample(2.0, 0.0)) == "rejected_mag_nan"
    assert c.reject(MagSample(1.0, 50000.0)) == "rejected_mag_out_of_order"       # same stamp again
    assert c.reject(MagSample(0.5, 50000.0)) == "rejected_mag_out_of_order"
    assert c.reject(MagSample(2.0, 50001.0)) is None                              # a rejected one moved nothing
    assert c.last_t_s == 2.0
