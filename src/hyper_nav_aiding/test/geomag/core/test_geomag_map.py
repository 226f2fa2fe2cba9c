"""The WMM map: accuracy against pygeomag, gradients, provenance checks,
refusal of bad and mismatched files, off-map errors."""
import json

import numpy as np
import pytest
from pygeomag import GeoMag

from hyper_nav_aiding.geomag.core.geomag_map import (
    GeomagMap, MapError, MapFileError, MapMismatchError, MapSpec, OffMapError, get_or_build, load_map,
)

SMALL = MapSpec(lat_min_deg=44.0, lat_max_deg=44.5, lon_min_deg=110.0, lon_max_deg=110.5, grid_step_deg=0.05,
                alt_m=26000.0)


@pytest.fixture(scope="module")
def small_map():
    return GeomagMap.build(SMALL)


def test_spline_reproduces_pygeomag_and_its_gradient(small_map):
    """Between nodes the spline is the WMM to 1e-3 nT at the map altitude;
    1 km above it the dF/dh layer keeps it within 0.02 nT (second-order
    term); gradients agree with pygeomag finite differences to 0.5 %."""
    gm = GeoMag()
    rng = np.random.default_rng(1)
    la, lo = rng.uniform(44.05, 44.45, 20), rng.uniform(110.05, 110.45, 20)
    f = small_map.total_nT(np.deg2rad(la), np.deg2rad(lo), np.full(20, 26000.0))
    ref = [gm.calculate(glat=a, glon=b, alt=26.0, time=2025.5).f for a, b in zip(la, lo)]
    assert np.max(np.abs(f - ref)) < 1e-3
    f1 = small_map.total_nT(np.deg2rad(la[:3]), np.deg2rad(lo[:3]), np.full(3, 27000.0))
    ref1 = [gm.calculate(glat=a, glon=b, alt=27.0, time=2025.5).f for a, b in zip(la[:3], lo[:3])]
    assert np.max(np.abs(f1 - ref1)) < 0.02
    lat, lon = 44.25, 110.25
    _, g = small_map.total_and_gradient(np.deg2rad(lat), np.deg2rad(lon), 26000.0)
    d = 1e-3
    from hyper_nav_gnss import earth
    r_m, r_n = earth.radii(np.deg2rad(lat))
    fn = (gm.calculate(glat=lat + d, glon=lon, alt=26.0, time=2025.5).f
          - gm.calculate(glat=lat - d, glon=lon, alt=26.0, time=2025.5).f) / (2 * d * np.pi / 180 * (r_m + 26e3))
    fe = (gm.calculate(glat=lat, glon=lon + d, alt=26.0, time=2025.5).f
          - gm.calculate(glat=lat, glon=lon - d, alt=26.0, time=2025.5).f) / (
        2 * d * np.pi / 180 * (r_n + 26e3) * np.cos(np.deg2rad(lat)))
    assert g[1] == pytest.approx(fn, rel=5e-3) and g[0] == pytest.approx(fe, rel=5e-3)
    assert 3e-3 < np.hypot(g[0], g[1]) < 4.5e-3          # 3-4.5 nT/km over this map (the physics)
    assert -0.035 < g[2] < -0.025                         # about -3 F / r: ~ -30 nT/km vertically


def test_components_agree_with_pygeomag_enu(small_map):
    r = GeoMag().calculate(glat=44.2, glon=110.3, alt=26.0, time=2025.5)
    b = small_map.vector_enu_nT(np.deg2rad(44.2), np.deg2rad(110.3), 26000.0)
    assert np.allclose(b, [r.y, r.x, -r.z], atol=1e-3)


def test_cache_round_trip_keeps_provenance(tmp_path, small_map):
    m = get_or_build(SMALL, tmp_path)
    files = list(tmp_path.glob("*.npz"))
    assert len(files) == 1
    m2 = load_map(files[0], SMALL)
    assert m2.provenance["source"] == "pygeomag" and m2.spec == SMALL
    assert np.array_equal(m.layers, m2.layers)


@pytest.mark.parametrize("field, value, word", [("epoch_decimal_year", 2026.0, "epoch_decimal_year"),
                                                ("alt_m", 25000.0, "alt_m"),
                                                ("grid_step_deg", 0.1, "grid_step_deg")])
def test_mismatched_map_is_refused_naming_the_field(tmp_path, small_map, field, value, word):
    path = small_map.save(tmp_path / "m.npz")
    from dataclasses import replace
    with pytest.raises(MapMismatchError, match=word):
        load_map(path, replace(SMALL, **{field: value}))


def test_bad_files_are_refused_with_a_clear_error(tmp_path, small_map):
    with pytest.raises(MapFileError, match="does not exist"):
        load_map(tmp_path / "none.npz", SMALL)
    (tmp_path / "junk.npz").write_bytes(b"not a map")
    with pytest.raises(MapFileError, match="not a readable geomagnetic map"):
        load_map(tmp_path / "junk.npz", SMALL)
    layers = small_map.layers.copy()
    layers[0, 2, 3] = np.nan
    meta = {"format_version": 1, "spec": SMALL.__dict__}
    np.savez(tmp_path / "nan.npz", layers=layers, provenance=np.array(json.dumps(meta)))
    with pytest.raises(MapFileError, match="non-finite"):
        load_map(tmp_path / "nan.npz", SMALL)
    np.savez(tmp_path / "short.npz", layers=layers[:, :3], provenance=np.array(json.dumps(meta)))
    with pytest.raises(MapFileError, match="shape"):
        load_map(tmp_path / "short.npz", SMALL)


def test_off_map_positions_raise(small_map):
    with pytest.raises(OffMapError, match="outside the map"):
        small_map.total_nT(np.deg2rad(44.6), np.deg2rad(110.2), 26000.0)
    with pytest.raises(OffMapError, match="leaves the map"):
        small_map.refined_window(44.49, 110.2, 100)


def test_spec_validation_names_the_field():
    with pytest.raises(MapError, match="refine_factor"):
        MapSpec(refine_factor=0)
    with pytest.raises(MapError, match="grid_step_deg"):
        MapSpec(grid_step_deg=0.03)          # 8 deg is not a whole number of 0.03 deg steps
    with pytest.raises(MapError, match="geomag.map: unknown"):
        MapSpec.from_dict({"altitude": 1.0}, prefix="geomag.map")
