"""US Standard Atmosphere 1976 against the published table (NOAA-S/T 76-1562)."""
import numpy as np
import pytest

from hyper_nav_filter.core import atmosphere

# geometric altitude [m]: T [K], P [Pa], rho [kg/m^3], a [m/s]  (1976 Table I)
TABLE = {
    0.0: (288.150, 101325.0, 1.2250, 340.29),
    11000.0: (216.774, 22699.9, 0.36480, 295.15),
    20000.0: (216.650, 5529.3, 8.8910e-2, 295.07),
    32000.0: (228.490, 889.06, 1.3555e-2, 303.02),
    47000.0: (269.680, 115.85, 1.4965e-3, 329.21),
    60000.0: (247.021, 21.958, 3.0968e-4, 315.07),
    80000.0: (198.639, 1.0524, 1.8458e-5, 282.54),
    86000.0: (186.87, 0.37338, 6.958e-6, 274.10),
    100000.0: (195.08, 3.2011e-2, 5.604e-7, None),
}


@pytest.mark.parametrize("z", sorted(TABLE))
def test_matches_the_1976_table(z):
    T, P, rho, a = atmosphere.atmosphere(z)
    T0, P0, rho0, a0 = TABLE[z]
    assert T == pytest.approx(T0, rel=5e-3)
    assert P == pytest.approx(P0, rel=5e-3)
    assert rho == pytest.approx(rho0, rel=5e-3)
    if a0 is not None:
        assert a == pytest.approx(a0, rel=5e-3)


def test_vectorised_monotone_and_continuous():
    z = np.linspace(0.0, 120000.0, 24001)
    T, P, rho, a = atmosphere.atmosphere(z)
    assert T.shape == P.shape == rho.shape == a.shape == z.shape
    assert np.all(np.isfinite(rho)) and np.all(np.diff(rho) < 0) and np.all(np.diff(P) < 0)
    # no jumps at the layer boundaries or at 86 km (5 m steps)
    assert np.max(np.abs(np.diff(np.log(rho)))) < 2e-3
    assert np.max(np.abs(np.diff(T))) < 0.1


def test_inverse_density():
    z = np.array([0.0, 5000.0, 11000.0, 25000.0, 47000.0, 55000.0, 75000.0, 90000.0, 115000.0])
    np.testing.assert_allclose(atmosphere.altitude_for_density_m(atmosphere.density_kgpm3(z)), z, atol=1e-6)


def test_named_tuple_interface():
    st = atmosphere.us76([0.0, 11000.0])
    np.testing.assert_allclose(st.pressure_pa, [101325.0, 22699.9], rtol=1e-5)
    assert st.temperature_K[0] == pytest.approx(288.15)


@pytest.mark.parametrize("z", [-500.0, 0.0, 5000.0, 11000.0, 25000.0, 32000.0, 47000.0, 51000.0, 60000.0, 71000.0,
                               80000.0, 85999.0, 86500.0, 100000.0, 130000.0])
def test_scalar_fast_paths_equal_the_vectorised_functions(z):
    """The flight dynamics' per-call scalar paths: the same density and its inverse (to 1e-12 relative)."""
    rho = atmosphere.density_kgpm3_scalar(z)
    assert rho == pytest.approx(float(atmosphere.density_kgpm3(z)), rel=1e-12)
    assert atmosphere.altitude_for_density_m_scalar(rho) == pytest.approx(
        float(atmosphere.altitude_for_density_m(rho)), rel=1e-12, abs=1e-6)
    assert atmosphere.altitude_for_density_m_scalar(rho) == pytest.approx(z, abs=1e-3)
