"""The ``spp`` command's work without the drawing: read receiver data (a
``ubx`` / ``rinex`` import description, or a bag with ``gnss/raw`` and
``gnss/ephemeris``), run single-point positioning
(:mod:`hyper_nav_gnss.positioning.spp`) in each configured *run* (signal
plan, weighting), RTKLIB's ``pntpos`` beside each run on the same data
(:mod:`.rtklib_reference`), and score all of them against a reference on the
epochs they share. No rclpy.

The description (YAML; paths relative to it; ``{real_data}`` in a path is
the ``--data-dir``)::

    preset: rinex                     # or ubx (the import_data presets)
    gnss: {file: obs.crx.gz, nav: brdc.rnx.gz}
    spp:
      elevation_mask_deg: 10.0
      p_fa: 1.0e-3                    # RAIM false-alarm probability per epoch
      weighting: elevation_cn0        # elevation | cn0 | elevation_cn0 (core/gnss/weighting.py)
      rtklib: true
      runs:                           # name -> signal plan (core/gnss/combinations.py)
        dual_frequency: {signals: {G: [1C+2W], E: [1X+7X], C: [2I+6I]}}
        gps_single_frequency: {signals: {G: [1C]}}
    reference:                        # one of
      xyz_m: [4627852.5264, 119640.5140, 4372994.8358]   # a fixed point (ECEF) ...
      antenna_height_m: 1.053         # ... raised along the ellipsoid normal (marker -> antenna reference point)
      # file: walk.pos                # an RTKLIB .pos trajectory ...
      # quality: 1                    # ... only these epochs (1 = fixed), matched within tolerance_s
      # tolerance_s: 0.005

Errors are ENU at the reference, metres: horizontal RMS = sqrt(mean(e^2 + n^2)),
vertical RMS = sqrt(mean(u^2)); the mean (bias) and the RMS about the mean
are given too (a trajectory whose absolute datum is off shows it as a bias
common to every solution).
"""
from __future__ import annotations

import copy
import pathlib
import time
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_gnss.positioning import spp as spp_core
from hyper_nav_gnss.corrections.combinations import parse_plan
from hyper_nav_gnss.observations import EphemerisStore, MalformedGnssInput
from hyper_nav_gnss.corrections.receiver_model import ReceiverModel
from hyper_nav_gnss.corrections.weighting import ErrorModel
from hyper_nav_gnss.formats.registry import RECEIVER_FORMATS, detect, receiver_format
from hyper_nav_filter.core.params import ConfigError, suggest


SPP_KNOWN = {"elevation_mask_deg", "p_fa", "weighting", "rtklib", "runs", "max_exclusions", "error_model"}
REF_KNOWN = {"xyz_m", "antenna_height_m", "file", "quality", "tolerance_s"}
DEFAULT_RUNS = {"dual_frequency": {"signals": {"G": ["1C+2W", "1C+2L", "1C+5Q", "1C+5X"],
                                               "E": ["1X+7X", "1C+7Q", "1C+5Q", "1X+5X"], "C": ["2I+6I"]}},
                "gps_single_frequency": {"signals": {"G": ["1C"]}}}


@dataclass
class SppInput:
    epochs: list
    records: list
    iono: dict
    source: str
    kind: str                      # rinex | ubx | bag
    read_wall_s: float
    counts: Counter = field(default_factory=Counter)
    errors: list = field(default_factory=list)
    files: dict = field(default_factory=dict)
    header: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)


def _resolve(value, base: pathlib.Path, data_dir) -> str:
    s = str(value)
    if "{real_data}" in s:
        if data_dir is None:
            raise ConfigError(f"{s}: needs --data-dir (the folder holding the shared real-data recordings)")
        s = s.replace("{real_data}", str(data_dir))
    p = pathlib.Path(s)
    return str(p if p.is_absolute() else base / p)


def load_description(path, data_dir=None) -> dict:
    """The YAML description with its paths resolved (see the module docstring)."""
    path = pathlib.Path(path)
    import yaml
    doc = yaml.safe_load(path.read_text())
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: expected a mapping")
    unknown = sorted(set(doc) - {"preset", "gnss", "spp", "reference", "imu", "filter", "report", "start_s",
                                 "end_s"})
    if unknown:
        raise ConfigError(f"{unknown[0]}: unknown field of an spp description")
    doc = copy.deepcopy(doc)
    base = path.parent
    g = doc.get("gnss") or {}
    for k in ("file", "nav"):
        if k in g:
            g[k] = _resolve(g[k], base, data_dir)
    ref = doc.get("reference") or {}
    if "file" in ref:
        ref["file"] = _resolve(ref["file"], base, data_dir)
    for k in set(doc.get("spp") or {}) - SPP_KNOWN:
        raise ConfigError(f"spp.{k}: unknown field (known: {', '.join(sorted(SPP_KNOWN))})")
    for k in set(ref) - REF_KNOWN:
        raise ConfigError(f"reference.{k}: unknown field (known: {', '.join(sorted(REF_KNOWN))})")
    doc["_base"] = str(base)
    return doc


def read_input(doc: dict, max_epochs: int | None = None) -> SppInput:
    """Receiver data of a ubx / rinex description."""
    preset = doc.get("preset")
    if preset not in RECEIVER_FORMATS:
        raise ConfigError(f"preset: expected a receiver format ({', '.join(RECEIVER_FORMATS)}), got {preset!r}"
                          f"{suggest(str(preset), RECEIVER_FORMATS) if isinstance(preset, str) else ''}")
    spec = {k: v for k, v in (doc.get("gnss") or {}).items() if k in ("file", "nav", "signals")}
    if RECEIVER_FORMATS[preset].needs_nav and "signals" not in spec:   # read only the codes some run uses
        want: dict = {}
        for run in ((doc.get("spp") or {}).get("runs") or DEFAULT_RUNS).values():
            for sysc, choices in (run.get("signals") or {}).items():
                for ch in ([choices] if isinstance(choices, str) else choices):
                    want.setdefault(sysc, set()).update(str(ch).split("+"))
        spec["signals"] = {k: sorted(v) for k, v in want.items()}
    t0 = time.perf_counter()
    from hyper_nav_workbench.core.importer import gnss_raw
    imp = gnss_raw.read_gnss(preset, spec, doc.get("_base", "."))
    wall = time.perf_counter() - t0
    epochs = imp.epochs[:max_epochs] if max_epochs else imp.epochs
    files = {"file": spec["file"], "nav": spec.get("nav")}
    return SppInput(epochs, [e for _, e in imp.ephemerides], dict(imp.iono), imp.source, preset, wall,
                    Counter(imp.counts), list(imp.errors), files, imp.header)


def plan_codes(runs: dict) -> dict:
    """{system: [codes]} every run's signal plan reads (the reader keeps only those)."""
    want: dict = {}
    for run in runs.values():
        for sysc, choices in (run.get("signals") or {}).items():
            for ch in ([choices] if isinstance(choices, str) else choices):
                want.setdefault(sysc, set()).update(str(ch).split("+"))
    return {k: sorted(v) for k, v in want.items()}


def read_files(obs_path, nav_paths, runs: dict, max_epochs: int | None = None) -> SppInput:
    """A RINEX observation file and one or more navigation files, as archives
    hold them (2.xx, 3.0x, 4.0x; gzip, .Z, zip, Hatanaka): the epochs of the
    codes the ``runs`` use (pseudoranges and C/N0: positions need no phase
    or Doppler), the broadcast records of the systems they use and
    the Klobuchar sets (the first file that has a system's set gives it).
    Refused (ConfigError naming the file): a file that does not exist, is
    not RINEX of the right type and version, or yields no epoch / no record."""
    from hyper_nav_gnss.formats.rinex_nav import RINEX3_SYSTEMS, read_rinex_nav
    t0 = time.perf_counter()
    paths = [pathlib.Path(obs_path)] + [pathlib.Path(n) for n in nav_paths]
    for p in paths:
        if not p.is_file():
            raise ConfigError(f"{p}: no such file")
    try:
        fmt = receiver_format(detect(obs_path) or "rinex")     # a RINEX file, or any registered receiver format
        obs = fmt.read(obs_path, signals=plan_codes(runs), max_epochs=max_epochs, observables="S")
    except ValueError as exc:
        raise ConfigError(f"observation file {exc}") from None
    if not obs.epochs:
        raise ConfigError(f"{obs_path}: no observation epoch with the signals asked for "
                          f"({plan_codes(runs)}; reader counts {dict(obs.counts)})")
    records, iono, counts, errors, notes = [], {}, Counter(obs.counts), list(obs.errors), []
    used = tuple(x for x in RINEX3_SYSTEMS if x in plan_codes(runs))     # only the records the runs can use
    for n in nav_paths:
        try:
            nav = read_rinex_nav(n, used)
        except ValueError as exc:
            raise ConfigError(f"navigation file {exc}") from None
        records += list(nav)
        for sysc, ab in nav.iono.items():
            iono.setdefault(sysc, ab)
        counts.update({f"nav_{k}": v for k, v in nav.counts.items()})
        errors += nav.errors[:20]
        notes += [f"{pathlib.Path(n).name}: {x}" for x in nav.notes]
    inp = SppInput(obs.epochs, records, iono, str(obs_path), fmt.name, time.perf_counter() - t0, counts, errors,
                   {"file": str(obs_path), "nav": [str(n) for n in nav_paths]}, obs.header or {})
    inp.notes = notes
    return inp


def header_reference(header: dict, source: str) -> "Reference":
    """The observation header's ``APPROX POSITION XYZ`` (the marker) raised by
    ``ANTENNA: DELTA H/E/N`` (H along the ellipsoid normal, E and N in the
    local level): the antenna reference point, the point a code solution
    without antenna phase-centre corrections estimates."""
    xyz = header.get("approx_xyz_m")
    if xyz is None or not np.any(np.asarray(xyz) != 0.0):
        raise ConfigError(f"--ref header: {source} has no (or a zero) APPROX POSITION XYZ")
    hen = np.asarray(header.get("antenna_delta_hen_m", np.zeros(3)), float)
    lat, lon, _ = earth.ecef_to_geodetic(np.asarray(xyz, float))
    arp = np.asarray(xyz, float) + earth.C_n_e(lat, lon) @ np.array([hen[1], hen[2], hen[0]])
    return Reference("point", arp, note=f"header APPROX POSITION XYZ {np.asarray(xyz).tolist()} + ANTENNA: DELTA "
                                        f"H/E/N {hen.tolist()} m (the antenna reference point)")


def parse_reference(spec: str, header: dict, source: str, quality=None, tolerance_s: float = 0.005):
    """``--ref``: ``header``, ``X,Y,Z`` (ECEF m), ``LAT,LON,H`` (deg, deg, m
    ellipsoidal; recognised by |LAT| <= 90 and |LON| <= 360) or an RTKLIB ``.pos`` file."""
    if spec == "header":
        return header_reference(header, source)
    p = pathlib.Path(spec)
    if p.suffix.lower() == ".pos" or p.is_file():
        if not p.is_file():
            raise ConfigError(f"--ref {spec}: no such file")
        try:
            return reference_of({"reference": {"file": str(p), "tolerance_s": tolerance_s,
                                               **({"quality": quality} if quality is not None else {})}})
        except ValueError as exc:
            raise ConfigError(f"--ref {spec}: {exc}") from None
    try:
        v = np.array([float(x) for x in spec.replace(";", ",").split(",")])
    except ValueError:
        raise ConfigError(f"--ref {spec!r}: expected 'header', X,Y,Z (ECEF m), LAT,LON,H (deg, m) "
                          "or an RTKLIB .pos file") from None
    if v.shape != (3,):
        raise ConfigError(f"--ref {spec!r}: expected three numbers")
    if abs(v[0]) <= 90.0 and abs(v[1]) <= 360.0:
        xyz = np.asarray(earth.geodetic_to_ecef(np.deg2rad(v[0]), np.deg2rad(v[1]), v[2]), float)
        return Reference("point", xyz, note=f"geodetic {v.tolist()} (deg, deg, m)")
    return Reference("point", v, note=f"ECEF {v.tolist()} m")


def read_bag_input(bag, max_epochs: int | None = None) -> SppInput:
    """``gnss/raw`` epochs and ``gnss/ephemeris`` records (and the Klobuchar sets
    the records carry) of a bag."""
    from hyper_nav_filter import conversions

    from hyper_nav_workbench.core.bag import deserialize, read_bag
    t0 = time.perf_counter()
    reader = read_bag(bag, ["/gnss/raw", "/gnss/ephemeris"])
    if not reader.topics:
        raise ConfigError(f"{bag}: no gnss/raw or gnss/ephemeris topic ({reader.error or 'empty bag'})")
    epochs, records, iono, counts, errors = [], [], {}, Counter(), []
    for rec in reader:
        msg = deserialize(rec.raw, rec.msgtype)
        if rec.topic.endswith("gnss/ephemeris"):
            try:
                records.append(conversions.gnss_ephemeris(msg))
            except (ValueError, TypeError) as exc:
                counts["malformed_ephemeris"] += 1
                errors.append(str(exc))
                continue
            kb = conversions.gnss_ephemeris_klobuchar(msg)
            if kb is not None:
                iono[kb[0]] = (kb[1], kb[2])
        else:
            if max_epochs and len(epochs) >= max_epochs:
                continue
            epochs.append(conversions.gnss_raw(msg))
    if not epochs:
        raise ConfigError(f"{bag}: no gnss/raw epoch")
    return SppInput(epochs, records, iono, str(bag), "bag", time.perf_counter() - t0, counts, errors)


@dataclass
class Reference:
    kind: str                       # point | trajectory
    xyz_m: np.ndarray | None = None
    pos: object = None
    tolerance_s: float = 0.005
    note: str = ""

    def at(self, t_gpst_s) -> tuple[np.ndarray, np.ndarray]:
        """(ECEF reference (n, 3), valid mask) at receiver times."""
        t = np.asarray(t_gpst_s, float)
        if self.kind == "point":
            return np.tile(self.xyz_m, (len(t), 1)), np.ones(len(t), bool)
        k = self.pos.match(t, self.tolerance_s)
        ok = k >= 0
        out = np.full((len(t), 3), np.nan)
        kk = k[ok]
        if len(kk):
            out[ok] = np.asarray(earth.geodetic_to_ecef(self.pos.lat_rad[kk], self.pos.lon_rad[kk],
                                                        self.pos.alt_m[kk])).reshape(-1, 3)
        return out, ok

    def origin(self) -> np.ndarray:
        if self.kind == "point":
            return self.xyz_m
        return np.asarray(earth.geodetic_to_ecef(self.pos.lat_rad[0], self.pos.lon_rad[0], self.pos.alt_m[0]))


def reference_of(doc: dict) -> Reference | None:
    ref = doc.get("reference")
    if not ref:
        return None
    if "xyz_m" in ref:
        xyz = np.asarray(ref["xyz_m"], float)
        if xyz.shape != (3,):
            raise ConfigError(f"reference.xyz_m: expected 3 numbers, got {ref['xyz_m']!r}")
        h = float(ref.get("antenna_height_m", 0.0))
        lat, lon, _ = earth.ecef_to_geodetic(xyz)
        return Reference("point", xyz + earth.C_n_e(lat, lon) @ np.array([0.0, 0.0, h]),
                         note=f"fixed point {xyz.tolist()} + {h} m along the normal")
    if "file" in ref:
        from hyper_nav_workbench.core.importer.rtklib_pos import read_pos
        pos = read_pos(ref["file"])
        q = ref.get("quality")
        if q is not None:
            pos = pos.select(pos.quality == int(q))
        return Reference("trajectory", pos=pos, tolerance_s=float(ref.get("tolerance_s", 0.005)),
                         note=f"{pathlib.Path(ref['file']).name}, quality {q} epochs ({len(pos.t_gpst_s)}), "
                              f"matched within {float(ref.get('tolerance_s', 0.005))} s")
    raise ConfigError("reference: give xyz_m or file")


def error_enu(pos_ecef, ref_ecef, origin) -> np.ndarray:
    lat, lon, _ = earth.ecef_to_geodetic(np.asarray(origin, float))
    return (np.asarray(pos_ecef, float) - np.asarray(ref_ecef, float)) @ earth.C_n_e(lat, lon)


def stats(enu) -> dict:
    e = np.asarray(enu, float).reshape(-1, 3)
    if not len(e):
        return {"epochs": 0}
    h = np.hypot(e[:, 0], e[:, 1])
    mean = e.mean(0)
    d = e - mean
    return {"epochs": int(len(e)), "horizontal_rms_m": float(np.sqrt(np.mean(h ** 2))),
            "vertical_rms_m": float(np.sqrt(np.mean(e[:, 2] ** 2))),
            "rms_3d_m": float(np.sqrt(np.mean(np.sum(e ** 2, 1)))),
            "mean_enu_m": [float(x) for x in mean],
            "horizontal_rms_about_mean_m": float(np.sqrt(np.mean(d[:, 0] ** 2 + d[:, 1] ** 2))),
            "vertical_rms_about_mean_m": float(np.sqrt(np.mean(d[:, 2] ** 2))),
            "horizontal_p95_m": float(np.percentile(h, 95)), "horizontal_max_m": float(h.max()),
            "vertical_max_abs_m": float(np.abs(e[:, 2]).max())}


def run_config(doc: dict, name: str, run: dict) -> spp_core.SppConfig:
    s = doc.get("spp") or {}
    em = dict(s.get("error_model") or {})
    em["weighting"] = run.get("weighting", s.get("weighting", em.get("weighting", "elevation_cn0")))
    try:
        plan = parse_plan(run["signals"])
        model = ReceiverModel(plan, ErrorModel(**em), None, True, np.deg2rad(float(s.get("elevation_mask_deg", 10.0))))
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"spp.runs.{name}: {exc}") from None
    return spp_core.SppConfig(model, p_fa=float(s.get("p_fa", 1e-3)), max_exclusions=int(s.get("max_exclusions", 4)))


class _PostProcessingStore(EphemerisStore):
    """Every record of the navigation files known from the start (post
    processing, as RTKLIB reads a navigation file): ``records_of`` skips the
    per-call filter on reception time (14 % of the solve time in the profile)."""

    def records_of(self, system: str, prn: int, received_by_s: float = float("inf")) -> list:
        return self._by_sat.get((system, int(prn)), [])


def run_ours(inp: SppInput, cfg: spp_core.SppConfig, precise=None) -> tuple[list, Counter, float]:
    store = _PostProcessingStore()          # records are added below with no reception time: the same choice
    counts = Counter()
    for e in inp.records:
        try:
            store.add(e)
        except MalformedGnssInput:
            counts["records_refused"] += 1
    from dataclasses import replace
    cfg = replace(cfg, model=replace(cfg.model, klobuchar=inp.iono or None))
    x0 = None
    xyz = inp.header.get("approx_xyz_m") if inp.header else None
    if xyz is not None and np.linalg.norm(xyz) > 6.0e6:         # the header's approximate position as the start
        x0 = np.r_[np.asarray(xyz, float), 0.0]
    t0 = time.perf_counter()
    sols = spp_core.solve(inp.epochs, store, cfg, counts, x0, precise=precise)
    return sols, counts, time.perf_counter() - t0


def load_precise(sp3_path, clk_path=None, epochs=(), atx_path=None):
    """The precise product of ``--sp3 FILE [--clk FILE] [--atx FILE]`` (hyper_nav_gnss/orbits/precise.py), refused
    (ConfigError naming both spans, GPST) unless it covers the observation span of ``epochs``."""
    from hyper_nav_gnss.formats.sp3 import read_sp3
    from hyper_nav_gnss.orbits.precise import PreciseEphemeris
    clocks = None
    if clk_path:
        from hyper_nav_gnss.formats.rinex_clk import read_rinex_clk
        clocks = read_rinex_clk(clk_path)
    antennas = None
    if atx_path:
        from hyper_nav_gnss.formats.antex import read_antex
        antennas = read_antex(atx_path)
    pe = PreciseEphemeris(read_sp3(sp3_path), clocks, antennas=antennas)
    if epochs:
        t0, t1 = float(epochs[0].t_rx_gpst_s), float(epochs[-1].t_rx_gpst_s)
        a, b = pe.span_gpst_s
        if t0 < a or t1 > b:
            what = f"{pe.orbits.source}" + (f" with {pe.clocks.source}" if clk_path else "")
            raise ConfigError(f"--sp3: {what} covers {_gpst_span(a, b)}, the observations span {_gpst_span(t0, t1)}: "
                              f"the product does not cover the observation span (give the product of the "
                              f"observation day)")
    return pe


def _gpst_span(a: float, b: float) -> str:
    from datetime import datetime, timedelta
    g = datetime(1980, 1, 6)
    f = "%Y-%m-%d %H:%M:%S"
    return f"{(g + timedelta(seconds=a)).strftime(f)} .. {(g + timedelta(seconds=b)).strftime(f)} GPST"


def precise_note(pe) -> str:
    """One line naming the precise orbits and clocks used (the .pos header, spp.json, the terminal)."""
    o = pe.orbits
    clk = (f"clocks {pe.clocks.source}" if pe.clocks.source != o.source else "clocks of the SP3")
    ant = (f"satellite antenna offsets {pe.antennas.source}" if pe.antennas is not None
           else "NO satellite antenna offsets")
    return (f"precise SP3-{o.version} {o.source} ({o.agency} {o.orbit_type}, {o.frame}, {o.interval_s:g} s, "
            f"{_gpst_span(*o.span_gpst_s)}; systems {''.join(pe.systems)}), {clk}, {ant}; other systems broadcast")


def run_rtklib(inp: SppInput, cfg: spp_core.SppConfig, times_gpst_s, elmask_deg: float):
    """RTKLIB beside one of our runs: same systems, IFLC if the run uses pairs, else BRDC."""
    from hyper_nav_workbench.core import rtklib_reference as rr
    systems = tuple(cfg.model.plan)
    dual = any(len(c) == 2 for ch in cfg.model.plan.values() for c in ch)
    t0 = time.perf_counter()
    if inp.kind == "rinex":
        sol = rr.postpos_rinex(inp.files["file"], inp.files["nav"], systems, dual, elmask_deg)
        wall = time.perf_counter() - t0
        sol.codes = rr.rinex_codes(inp.files["file"], systems)
        return sol, wall
    elif inp.kind == "ubx":
        sol = rr.solve_ubx(inp.files["file"], inp.records, inp.iono, systems, dual, elmask_deg)
    else:
        raise ConfigError("RTKLIB runs on RINEX or UBX files, not on a bag")
    return sol, time.perf_counter() - t0


def evaluate(inp: SppInput, doc: dict, ref: Reference | None, with_rtklib: bool, progress=None,
             precise=None) -> dict:
    """Every run, RTKLIB beside it, scored on common epochs; the result dict of the command.
    ``precise``: a PreciseEphemeris used for the systems it holds (hyper_nav_gnss/positioning/spp.py
    ``precise_states``; RTKLIB beside stays on broadcast orbits)."""
    s = doc.get("spp") or {}
    runs = s.get("runs") or DEFAULT_RUNS
    mask = float(s.get("elevation_mask_deg", 10.0))
    out = {"source": inp.source, "kind": inp.kind, "read_wall_s": inp.read_wall_s, "epochs": len(inp.epochs),
           "records": len(inp.records), "reader_counts": dict(inp.counts), "reader_errors": inp.errors[:10],
           "reference": ref.note if ref else None, "runs": {}}
    for name, run in runs.items():
        cfg = run_config(doc, name, run)
        if progress:
            progress(f"run {name}")
        sols, counts, wall = run_ours(inp, cfg, precise)
        t = np.array([x.t_rx_gpst_s for x in sols])
        valid = np.array([x.valid for x in sols])
        pos = np.array([x.pos_ecef_m for x in sols]).reshape(-1, 3)
        r = {"signals": {k: ["+".join(c) for c in v] for k, v in cfg.model.plan.items()},
             **({"orbits": precise_note(precise)} if precise is not None else {}),
             "weighting": cfg.model.errors.weighting, "p_fa": cfg.p_fa, "elevation_mask_deg": mask,
             "wall_s": wall, "ms_per_epoch": 1e3 * wall / max(len(sols), 1), "counts": dict(counts),
             "status": dict(Counter(x.status for x in sols)),
             "exclusions": dict(Counter(e[0] for x in sols for e in x.excluded)),
             "mean_satellites_used": float(np.mean([x.n_used for x in sols if x.valid])) if valid.any() else 0.0,
             "mean_pdop": float(np.nanmean([x.dop.get("pdop", np.nan) for x in sols if x.valid])) if valid.any()
             else float("nan")}
        single = sorted({k for k, v in cfg.model.plan.items() for c in v if len(c) == 1})
        r["warnings"] = [f"no Klobuchar set for {k} in the navigation data: its single-frequency signals run "
                         f"WITHOUT an ionosphere model (metres of error)" for k in single if k not in (inp.iono or {})]
        if precise is not None and precise.antennas is None:
            r["warnings"].append(
                "precise orbits without --atx: the satellites' antenna phase-centre offsets are not applied (SP3 "
                "orbits are centres of mass; broadcast minus precise along nadir measured 0.6-1.6 m by GPS "
                "satellite on 2021-04-28): decimetre-to-metre errors")
        series = {"t_gpst_s": t.tolist(), "valid": valid.tolist(),
                  "clock_bias_m": [x.clock_bias_m for x in sols],
                  "isb_m": [x.isb_m for x in sols], "n_used": [x.n_used for x in sols],
                  "pdop": [x.dop.get("pdop", np.nan) for x in sols], "hdop": [x.dop.get("hdop", np.nan) for x in sols],
                  "vdop": [x.dop.get("vdop", np.nan) for x in sols],
                  "excluded": [[e[0] for e in x.excluded] for x in sols]}
        rk = None
        if with_rtklib and s.get("rtklib", True) and inp.kind in ("rinex", "ubx"):
            if progress:
                progress(f"run {name}: RTKLIB")
            try:
                rk, rk_wall = run_rtklib(inp, cfg, t[valid], mask)
                r["rtklib"] = {"wall_s": rk_wall, "epochs": int(len(rk.t_gpst_s)), "solved": int(rk.ok.sum()),
                               "mean_satellites": float(np.mean(rk.n_sat[rk.ok])) if rk.ok.any() else 0.0,
                               "codes": rk.codes, "engine": getattr(rk, "engine", "pntpos"),
                               "ionosphere": "IFLC" if any(
                                   len(c) == 2 for v in cfg.model.plan.values() for c in v) else "BRDC"}
            except (ImportError, RuntimeError, OSError) as exc:
                r["rtklib"] = {"error": f"{type(exc).__name__}: {exc}"}
                rk = None
        if ref is not None:
            ref_xyz, ref_ok = ref.at(t)
            origin = ref.origin()
            ours_ok = valid & ref_ok
            r["ours_all"] = stats(error_enu(pos[ours_ok], ref_xyz[ours_ok], origin))
            common = ours_ok.copy()
            if rk is not None:
                kk = np.array([np.argmin(np.abs(rk.t_gpst_s - tt)) if len(rk.t_gpst_s) else -1 for tt in t])
                rk_ok = np.array([k >= 0 and abs(rk.t_gpst_s[k] - tt) < 0.01 and rk.ok[k] for k, tt in zip(kk, t)])
                common &= rk_ok
                r["rtklib_same_epochs"] = stats(error_enu(rk.pos_ecef_m[kk[common]], ref_xyz[common], origin))
                series["rtklib_err_enu_m"] = np.where(
                    rk_ok[:, None] & ref_ok[:, None], error_enu(rk.pos_ecef_m[np.maximum(kk, 0)], ref_xyz, origin),
                    np.nan).tolist()
            r["ours_same_epochs"] = stats(error_enu(pos[common], ref_xyz[common], origin))
            series["err_enu_m"] = np.where(ours_ok[:, None], error_enu(pos, ref_xyz, origin), np.nan).tolist()
        r["series"] = series
        r["_solutions"] = sols
        out["runs"][name] = r
    return out
