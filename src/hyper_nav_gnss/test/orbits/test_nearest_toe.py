"""NearestToe (bisection over a satellite's records) picks the record
select_ephemeris picks: nearest toe, healthy only, the preferred Galileo
clock first, a tie to the first in list order, the age limit; and the
store's ``choose`` follows added records."""
from dataclasses import replace

from hypothesis import given, settings
from hypothesis import strategies as st

from hyper_nav_gnss.observations import EphemerisStore
from hyper_nav_gnss.orbits.ephemeris import (GAL_CLOCK_E1E5A, GAL_CLOCK_E1E5B, SECONDS_PER_WEEK, BroadcastEphemeris,
                                             NearestToe, select_ephemeris)

BASE = BroadcastEphemeris("E", 11, 0.0, 0.0, 2295, 5440.6, 0.01, 0.96, 1.0, 0.5, 0.2, 4e-9, 0.0, -8e-9,
                          0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0)

# toes on a 10-minute grid (ties at midpoints happen), a few weeks, health and clock source drawn
record = st.tuples(st.integers(0, 3), st.integers(0, 60), st.sampled_from([0, 0, 0, 1]),
                   st.sampled_from([0, GAL_CLOCK_E1E5A, GAL_CLOCK_E1E5B, GAL_CLOCK_E1E5A | GAL_CLOCK_E1E5B]),
                   st.integers(0, 999))


def _records(spec):
    return [replace(BASE, week=2295 + w, toe=600.0 * k, toc=600.0 * k, health=h, data_source=src, iode=iode)
            for w, k, h, src, iode in spec]


@settings(max_examples=150, deadline=None)
@given(spec=st.lists(record, min_size=1, max_size=30),
       clock=st.sampled_from([0, GAL_CLOCK_E1E5A, GAL_CLOCK_E1E5B]),
       max_age=st.sampled_from([None, 600.0, 1e9]))
def test_the_record_select_ephemeris_picks(spec, clock, max_age):
    recs = _records(spec)
    ix = NearestToe(recs)
    for w in range(4):                         # every 5 min of the records' span, the midpoints (ties) included
        for n in range(-10, 130):
            for offset in (0.0, 1e-7, 150.0):
                t = (2295 + w) * SECONDS_PER_WEEK + 300.0 * n + offset
                assert ix.select(t, max_age, clock) is select_ephemeris(recs, "E11", t, max_age, clock)


def test_a_tie_goes_to_the_first_record_in_list_order():
    """Midway between two toes, the record listed first (here the later toe)."""
    late, early = _records([(0, 1, 0, 0, 1), (0, 0, 0, 0, 2)])
    t = 2295 * SECONDS_PER_WEEK + 300.0
    assert NearestToe([late, early]).select(t) is late is select_ephemeris([late, early], "E11", t)
    assert NearestToe([early, late]).select(t) is early


def test_store_choose_follows_added_records():
    store = EphemerisStore()
    a = replace(BASE, toe=0.0, toc=0.0)
    store.add(a)
    t = 2295 * SECONDS_PER_WEEK + 7000.0
    assert store.choose(store.records_of("E", 11), t) is a
    b = replace(BASE, toe=7200.0, toc=7200.0)
    store.add(b)                                          # the index of E11 is built again
    assert store.choose(store.records_of("E", 11), t) is b
    assert store.choose([a], t) is a                      # a list that is not the store's own: the scan
