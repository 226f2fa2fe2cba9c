"""The simulated static station (core/gnss/station.py): its observables obey
the model it states, per signal, on the real broadcast records of a day."""
import numpy as np
import pytest

from hyper_nav_gnss.corrections.signal_delays import group_delay_s
from hyper_nav_gnss.formats.rinex_nav import read_rinex_nav
from hyper_nav_gnss.orbits.ephemeris import C_MPS, calendar_to_system_s
from hyper_nav_gnss.signals import frequency_hz
from hyper_nav_sim.core.gnss.station import IGS_SIGNALS, _by_satellite, obs_types, simulate_station

from ._data import TLSE_NAV, real_data_file

XYZ = np.array([4627852.5264, 119640.5140, 4372994.8358])


@pytest.fixture(scope="module")
def nav():
    return read_rinex_nav(real_data_file(TLSE_NAV))


def test_signals_layout_and_visibility(nav):
    t0 = calendar_to_system_s("G", 2024, 1, 1, 6, 0, 0)
    eps, types = simulate_station(nav, XYZ, t0, t0 + 120.0, 30.0, seed=3)
    assert types == obs_types(IGS_SIGNALS) and len(types["E"]) == 16
    assert [t for t, _ in eps] == [t0, t0 + 30.0, t0 + 60.0, t0 + 90.0, t0 + 120.0]
    for _, sats in eps:
        by_sys = {s: sum(k[0] == s for k in sats) for s in "GEC"}
        assert by_sys["G"] >= 6 and by_sys["E"] >= 5 and by_sys["C"] >= 5, by_sys   # a mid-latitude sky
        for sid, vals in sats.items():
            assert set(vals) == set(types[sid[0]])


def test_code_and_phase_obey_the_ionosphere_and_group_delays(nav):
    """Noise off: C1C - C2W = I1 (1 - g12) + c (d1 - d2) with g12 = (f1/f2)^2
    (ionosphere and TGD of the record); code minus phase = 2 I_s + c d_s +
    whole cycles (phase advance)."""
    t0 = calendar_to_system_s("G", 2024, 1, 1, 12, 0, 0)
    eps, _ = simulate_station(nav, XYZ, t0, t0, 30.0, noise=False)
    recs = _by_satellite(nav, {"G"})
    f1, f2 = frequency_hz("G", "1C"), frequency_hz("G", "2W")
    g12 = (f1 / f2) ** 2
    checked = 0
    for sid, v in eps[0][1].items():
        if sid[0] != "G":
            continue
        e = recs[sid].select(t0, 7200.0)
        d1, d2 = group_delay_s(e, "1C"), group_delay_s(e, "2W")
        i1 = (v["C1C"] - v["C2W"] - C_MPS * (d1 - d2)) / (1.0 - g12)
        assert 0.5 < i1 < 40.0, (sid, i1)                         # a Klobuchar slant delay on L1 (m)
        lam1 = C_MPS / f1
        n1 = (v["C1C"] - C_MPS * d1 - 2.0 * i1 - lam1 * v["L1C"]) / lam1
        assert abs(n1 - round(n1)) < 1e-3, (sid, n1)
        checked += 1
    assert checked >= 6
