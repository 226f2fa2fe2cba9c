"""The offline replay on arrays (hyper_nav_filter.offline_arrays, core/array_io)
against the per-message reference path: the same solutions bit for bit, the
same counters, the same scores to 1e-12 and the same text files."""
import pathlib

import numpy as np
import pytest

from hyper_nav_filter.offline import run_offline
from hyper_nav_filter.offline_arrays import RowView, run_offline_arrays
from hyper_nav_workbench.core import array_io, scoring
from hyper_nav_workbench.core.bag import deserialize, read_bag
from hyper_nav_workbench.core.bag_arrays import read_arrays
from hyper_nav_workbench.core.importer import columns, kfgins, score
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_workbench.graph import bag_scenario

BAG = pathlib.Path(__file__).resolve().parents[3] / "bags" / "sample_short"


@pytest.fixture(scope="module")
def both():
    sc = load_scenario(bag_scenario(BAG))
    args = (sc.filter_config(), sc.filter_initial_state(), sc.filter_sources())
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(BAG)]
    ref, eng_ref = run_offline(records, *args, final=True)
    arrays = read_arrays(BAG)
    fast, eng_fast, router = run_offline_arrays(list(arrays.topics.values()), *args, final=True)
    return ref, eng_ref, fast, eng_fast, router, records, arrays


def test_replay_on_arrays_gives_the_per_message_solutions_bit_for_bit(both):
    ref, eng_ref, fast, eng_fast, router, _, _ = both
    assert len(ref) == len(fast) > 900
    for a, b in zip(ref, fast):
        assert a.t_s == b.t_s and a.mode == b.mode and a.n_updates == b.n_updates
        assert np.array_equal(a.P, b.P)
        sa, sb = a.state, b.state
        assert (sa.lat_rad, sa.lon_rad, sa.alt_m) == (sb.lat_rad, sb.lon_rad, sb.alt_m)
        assert np.array_equal(sa.vel_enu_mps, sb.vel_enu_mps) and np.array_equal(sa.C_b_n, sb.C_b_n)
    assert dict(eng_ref.counters) == dict(eng_fast.counters)
    # the sources' own counters (what /diagnostics reports), as the per-message router counts them
    from hyper_nav_filter.sources.router import SourceRouter
    from hyper_nav_filter.core.fusion import FusionEngine
    sc = load_scenario(bag_scenario(BAG))
    ref_router = SourceRouter(FusionEngine(sc.filter_config(), sc.filter_initial_state()), sc.filter_sources())
    for topic, msg in both[5]:
        ref_router.handle_topic(topic, msg)
    assert ref_router.diagnostics() == router.diagnostics()


def test_a_row_view_reads_like_the_message(both):
    *_, records, arrays = both
    fix = arrays.topics["/gnss/fix"]
    msg = next(m for t, m in records if t == "/gnss/fix")
    v = RowView(fix.fields, 0)
    assert v.header.stamp.sec == msg.header.stamp.sec and v.header.frame_id == msg.header.frame_id
    assert v.latitude == msg.latitude and np.array_equal(v.position_covariance, msg.position_covariance)
    assert v.status.status == msg.status.status
    with pytest.raises(AttributeError):
        v.no_such_field


def test_array_states_and_text_equal_the_per_message_reference(both, tmp_path):
    """The truth read as arrays gives the per-message states (the rotations
    from one quaternion stack to 1e-15), hence the same scores; the truth
    table's rotations (one Euler stack) equal the per-row closed form; the
    text tables are np.savetxt's, character for character."""
    from hyper_nav_filter.core.attitude import euler_to_C_b_n
    ref, *_, records, arrays = both
    nav = scoring.states_from_solutions(ref)
    truth_ref = scoring.states_from_msgs([m for t, m in records if t == "/truth/state"])
    truth_arr = array_io.states_from_topic(arrays.topics["/truth/state"])
    for k in ("t", "lat", "lon", "alt", "vel"):
        assert np.array_equal(truth_ref[k], truth_arr[k]), k
    np.testing.assert_allclose(truth_arr["C"], truth_ref["C"], rtol=0, atol=1e-15)
    a, b = scoring.errors(nav, truth_ref), scoring.errors(nav, truth_arr)
    assert np.array_equal(a["t"], b["t"]) and len(a["t"]) > 900
    for k in ("pos_enu_m", "vel_enu_mps", "att_enu_deg"):
        np.testing.assert_allclose(b[k], a[k], rtol=0, atol=1e-12)
    # against a truth table sampled elsewhere (the --truth file path): every other truth epoch
    tr = arrays.topics["/truth/state"]
    rph = np.column_stack([tr["roll_rad"], tr["pitch_rad"], tr["heading_rad"]])
    table = columns.FixTable(truth_arr["t"][::2], truth_arr["lat"][::2], truth_arr["lon"][::2],
                             truth_arr["alt"][::2], vel_enu_mps=truth_arr["vel"][::2], rph_rad=rph[::2])
    at = score.truth_at(table, table.t_s)
    per_row = np.array([euler_to_C_b_n(*r) for r in table.rph_rad])
    np.testing.assert_allclose(at["C"], per_row, rtol=0, atol=1e-14)
    e = score.errors_against(nav, table)
    assert len(e["t"]) > 400 and np.abs(e["att_enu_deg"]).max() < 1.0
    # the text files: np.savetxt's text, character for character (NaN columns included)
    rows = kfgins.std_rows(nav["t"], {"pos": np.abs(a["pos_enu_m"][:len(nav["t"])])[:, :3]}) \
        if len(a["pos_enu_m"]) >= len(nav["t"]) else kfgins.std_rows(nav["t"][:5], {})
    np.savetxt(tmp_path / "ref.txt", rows, fmt="%.9f", delimiter=" ")
    array_io.write_rows(tmp_path / "fast.txt", rows)
    assert (tmp_path / "fast.txt").read_text() == (tmp_path / "ref.txt").read_text()


@pytest.mark.parametrize("default_sigma", [(0.0, 0.0, 0.0), (3.0, 3.0, 5.0)])
def test_column_converted_fixes_equal_the_row_views_with_rejections(both, monkeypatch, default_sigma):
    """The GNSS fixes and velocities converted column by column
    (``SourceType.prepare_rows``) against the same rows read through
    ``RowView`` and the sources' per-message ``convert``: fixes without a fix
    (status -1) and without a covariance (type 0: rejected, or given the
    source's default sigmas) rejected and counted alike, the same solutions
    bit for bit and the same diagnostics."""
    from hyper_nav_filter.sources.base import SourceType
    from hyper_nav_filter.sources.gnss import GnssFixSource, GnssVelSource
    *_, arrays = both
    topics = []
    for t in arrays.topics.values():
        if t.topic == "/gnss/fix":
            f = {k: np.array(v, copy=True) for k, v in t.fields.items()}
            f["status.status"][[3, 40]] = -1
            f["position_covariance_type"][[5, 41, 90]] = 0
            t = type(t)(**{**{k: getattr(t, k) for k in t.__dataclass_fields__}, "fields": f})
        topics.append(t)
    sc = load_scenario(bag_scenario(BAG))
    sources = sc.filter_sources()
    for spec in sources.values():
        if spec.get("type") == "gnss_fix":
            spec["default_sigma_enu_m"] = list(default_sigma)
    args = (sc.filter_config(), sc.filter_initial_state(), sources)
    fast, eng_fast, router_fast = run_offline_arrays(topics, *args, final=True)
    for cls in (GnssFixSource, GnssVelSource):             # back to one RowView per message
        monkeypatch.setattr(cls, "prepare_rows", SourceType.prepare_rows)
    rows, eng_rows, router_rows = run_offline_arrays(topics, *args, final=True)
    assert len(fast) == len(rows) > 900
    for a, b in zip(rows, fast):
        assert a.t_s == b.t_s and a.n_updates == b.n_updates and np.array_equal(a.P, b.P)
        assert (a.state.lat_rad, a.state.lon_rad, a.state.alt_m) == (b.state.lat_rad, b.state.lon_rad, b.state.alt_m)
    assert dict(eng_rows.counters) == dict(eng_fast.counters)
    diag = router_fast.diagnostics()
    assert diag == router_rows.diagnostics()
    assert diag["rejected gnss/fix (no_fix)"] == 2
    if default_sigma[0] == 0.0:
        assert diag["rejected gnss/fix (no_covariance)"] == 3
    else:
        assert "rejected gnss/fix (no_covariance)" not in diag


def test_the_replay_leaves_the_garbage_collector_as_it_found_it(both):
    """The replay loop runs without automatic collections (``offline_arrays``'s
    ``_young_collections_only``) and restores the collector's state, on
    return and when the loop raises."""
    import gc
    *_, arrays = both
    sc = load_scenario(bag_scenario(BAG))
    args = (sc.filter_config(), sc.filter_initial_state(), sc.filter_sources())
    topics = list(arrays.topics.values())
    seen = []
    assert gc.isenabled()
    run_offline_arrays(topics, *args, progress=lambda k: seen.append(gc.isenabled()))
    assert seen and not any(seen) and gc.isenabled()
    with pytest.raises(RuntimeError):
        run_offline_arrays(topics, *args, progress=lambda k: (_ for _ in ()).throw(RuntimeError("stop")))
    assert gc.isenabled()
    gc.disable()
    try:
        run_offline_arrays(topics, *args)
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_raw_gnss_messages_beside_imu_arrays_give_the_per_message_solutions(tmp_path):
    """A tightly coupled real recording (walk_0827, first 20 s after the
    alignment, imported as a user does): ``replay_filter``'s core with the
    IMU on arrays and the raw GNSS and ephemeris messages deserialized
    (``MessageTopic``) gives ``run_offline``'s solutions and counters bit
    for bit."""
    from hyper_nav_filter.filter_setup import FilterSetup
    from hyper_nav_filter.offline_arrays import MessageTopic
    from hyper_nav_workbench import import_data
    from hyper_nav_repro.walk import reproduce as repro_walk
    from hyper_nav_workbench.core.importer import gnss_raw
    from hyper_nav_workbench.replay_filter import PER_MESSAGE_TYPES
    from hyper_nav_workbench.spp import default_data_dir
    if not (default_data_dir() / "walk_0827" / "imu_1730_sf.csv").exists():
        pytest.skip("shared walk_0827 data not found")
    imported = import_data.load_import(repro_walk.walk_yaml())
    t_al = imported["alignment"].t_s
    imported["imu"] = columns.window(imported["imu"], None, t_al + 20.0)
    imported["gnss_raw"] = gnss_raw.window(imported["gnss_raw"], t_al - 0.5, t_al + 20.0)
    bag = tmp_path / "walk"
    import_data.write(imported, bag)
    setup = FilterSetup.load(bag / "filter.yaml")
    args = (setup.config, setup.initial, setup.sources)
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(bag)]
    ref, eng_ref = run_offline(records, *args, final=True)
    arrays = read_arrays(bag)
    topics = [t for t in arrays.topics.values() if t.msgtype not in PER_MESSAGE_TYPES]
    raw = {t.topic for t in arrays.topics.values() if t.msgtype in PER_MESSAGE_TYPES}
    assert raw == {"/gnss/raw", "/gnss/ephemeris"}
    for name in sorted(raw):
        rows = [(r.t_ns, deserialize(r.raw, r.msgtype)) for r in read_bag(bag, topics=[name])]
        topics.append(MessageTopic(name, arrays.topics[name].msgtype, [m for _, m in rows], [n for n, _ in rows]))
    fast, eng_fast, _ = run_offline_arrays(topics, *args, final=True)
    assert eng_ref.kf.stats["pseudorange"][0] > 500
    assert len(ref) == len(fast) > 150
    for a, b in zip(ref, fast):
        assert a.t_s == b.t_s and a.n_updates == b.n_updates and np.array_equal(a.P, b.P)
        assert (a.state.lat_rad, a.state.lon_rad, a.state.alt_m) == (b.state.lat_rad, b.state.lon_rad, b.state.alt_m)
    assert dict(eng_ref.counters) == dict(eng_fast.counters)
