"""Signal environment: link budget, body antenna pattern, plasma-sheath attenuation."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hyper_nav_sim.core.gnss.signal_env import (
    AntennaPattern, PlasmaSheath, SignalEnvironment, off_boresight_rad, plasma_attenuation_db,
)

F_L1 = 1575.42e6


def test_zenith_link_budget_by_hand():
    env = SignalEnvironment()
    # level vehicle, antenna up, satellite at zenith: P = -157 dBW, G = +3 dBic, L = 1 dB,
    # N0 = -228.6 + 10 log10(513) = -201.50 dBW/Hz -> C/N0 = 46.50 dB-Hz
    cn0 = env.cn0_dbhz(0.0, np.array([np.pi / 2]), np.array([0.0]), np.eye(3))
    assert cn0[0] == pytest.approx(-157.0 + 3.0 - 1.0 + 228.6 - 10 * np.log10(513.0), abs=1e-9)
    assert cn0[0] == pytest.approx(46.50, abs=0.01)


def test_antenna_turned_over_loses_the_zenith_satellite():
    env = SignalEnvironment()
    el, az = np.array([np.pi / 2, np.deg2rad(30.0)]), np.array([0.0, np.deg2rad(90.0)])
    up = env.cn0_dbhz(0.0, el, az, np.eye(3))
    C_inv = Rotation.from_euler("x", 180, degrees=True).as_matrix()      # rolled 180 deg
    down = env.cn0_dbhz(0.0, el, az, C_inv)
    assert up[0] - down[0] == pytest.approx(3.0 - (-20.0), abs=1e-9)     # boresight -> back lobe
    # 30 deg elevation: 60 deg off boresight upright (-1 dBic), 120 deg inverted (-15 dBic)
    assert up[1] - down[1] == pytest.approx(-1.0 - (-15.0), abs=1e-9)


def test_off_boresight_angle_follows_attitude():
    C = Rotation.from_euler("y", 40, degrees=True).as_matrix()             # pitched 40 deg about body y
    th = off_boresight_rad(np.array([np.pi / 2]), np.array([0.0]), C)
    assert np.rad2deg(th[0]) == pytest.approx(40.0, abs=1e-9)


def test_plasma_slab_against_cold_plasma_closed_form():
    w = 2 * np.pi * F_L1
    n_c = 8.8541878128e-12 * 9.1093837015e-31 * w ** 2 / 1.602176634e-19 ** 2
    assert n_c == pytest.approx(3.078e16, rel=1e-3)                        # L1 critical density
    # collisionless, above critical: evanescent, alpha = (w/c) sqrt(wp^2/w^2 - 1)
    a = plasma_attenuation_db(4 * n_c, 0.0, 0.05, F_L1)
    assert a == pytest.approx(20 * np.log10(np.e) * w / 299792458.0 * np.sqrt(3.0) * 0.05, rel=1e-9)
    assert a == pytest.approx(24.8, abs=0.1)
    assert plasma_attenuation_db(0.5 * n_c, 0.0, 0.05, F_L1) < 1e-9        # transparent below critical


def test_plasma_profiles_table_and_model():
    tab = PlasmaSheath(mode="table", t_s=(10.0, 20.0, 30.0), att_db=(0.0, 40.0, 0.0))
    assert tab.attenuation_db(np.array([5.0, 15.0, 20.0, 40.0])).tolist() == [0.0, 20.0, 40.0, 0.0]
    mod = PlasmaSheath(mode="model")
    a = mod.attenuation_db(0.0, alt_m=np.array([40e3, 40e3, 40e3]), mach=np.array([8.0, 12.0, 16.0]))
    assert a[0] < 0.1 and a[2] > 30.0 and np.all(np.diff(a) > 0)
    assert mod.attenuation_db(0.0, alt_m=40e3, mach=30.0) == mod.max_db


@pytest.mark.parametrize("kw, msg", [
    (dict(mode="table", t_s=(0.0, np.nan), att_db=(0.0, 1.0)), "non-finite"),
    (dict(mode="table", t_s=(1.0, 0.0), att_db=(0.0, 1.0)), "increasing"),
    (dict(mode="table", t_s=(0.0, 1.0), att_db=(0.0, -1.0)), ">= 0 dB"),
    (dict(mode="sheath"), "mode"),
])
def test_bad_plasma_config_rejected(kw, msg):
    with pytest.raises(ValueError, match=msg):
        PlasmaSheath(**kw)


def test_from_dict_and_bad_fields():
    env = SignalEnvironment.from_dict({"t_sys_k": 290.0, "plasma": {"mode": "table", "t_s": [0, 1], "att_db": [5, 5]},
                                       "antenna": {"boresight_b": [0, 0, 1]}})
    assert env.n0_dbw_per_hz == pytest.approx(-228.6 + 10 * np.log10(290.0))
    with pytest.raises(ValueError, match="unknown field"):
        SignalEnvironment.from_dict({"tsys": 1})
    with pytest.raises(ValueError, match="boresight"):
        AntennaPattern(boresight_b=(0.0, 0.0, 0.0))
