"""import_data: recorded IMU/GNSS text files from outside the project -> a
rosbag2/MCAP bag for the fusion node and ``replay_filter``.

    ros2run hyper_nav_workbench import_data import.yaml --out bags/my_drive

``import.yaml`` (paths relative to it)::

    preset: kfgins                 # column maps of the KF-GINS formats (or give them, see core/importer/columns.py)
    kfgins_config: kf-gins.yaml    # optional: noise, initial state, lever arm and window from a KF-GINS config
    imu:   {file: Leador-A15.txt}  # + column map fields (time, kind, gyro, accel, body, ...)
    gnss:  {file: GNSS-RTK.txt}
    truth: {file: truth.nav}       # optional: recorded as truth/state, scores the run
    start_s: 456300                # optional processing window (data time, s)
    end_s: 456800
    filter:                        # this project's filter block (over the kfgins_config one, if any)
      config: {...}                # noise per axis, in any declared unit (core/params aliases)
      initial_state: {...}         # omitted: from the truth at the first IMU epoch
    report: {skip_s: 0.0}

Writes ``<out>/`` (``<out>.mcap`` + ``metadata.yaml``: imu/data_raw,
gnss/fix, gnss/vel when the GNSS file has velocities, truth/state) and
``<out>/filter.yaml``, the validated filter setup ``replay_filter`` uses.

An RTKLIB solution as the GNSS input (``preset: rtklib``,
``core/importer/rtklib_pos.py``): the ``gnss`` block names a ``.pos`` file
(``%`` header, GPST date and time, Q, sdn/sde/sdu, vn/ve/vu), with
``quality`` (the Q values kept) and ``sigma_scale`` (a factor on the sigmas
per Q), both stated at import; its time axis is continuous GPST, so the IMU
needs GPST stamps too: a logger's millisecond tick maps through an RTKLIB
time-tag file (``imu.time: {column: 0, unit: ms, tag: rover.ubx.tag}``) or
a counter table (``imu.time.map``), ``imu.time.offset_s`` shifts the IMU's
stamps (``core/importer/columns.py``). IMU and GNSS time axes that do not
overlap are an error naming both spans. Every field of the description is
checked: an unknown one is refused with the closest known name.

IMU noise (``core/noise_check.py``): on the static intervals (the alignment
window, GNSS standstills) the IMU's white noise is measured (Allan
deviation where an interval holds 10 s, else the raw scatter) and printed
against the configured densities, with a suggested configuration; it is
saved as ``<out>/noise_check.yaml`` for ``replay_filter``.
``--noise from-data`` adopts the suggestion (per axis max(configured,
measured)) in filter.yaml.

Real receiver data (``preset: ubx`` or ``preset: rinex``,
``core/importer/gnss_raw.py``): the ``gnss`` block names a u-blox UBX log
or RINEX 3 observation + navigation files, and the bag gets ``gnss/raw``
and ``gnss/ephemeris`` (transient local) instead of fixes::

    preset: ubx
    gnss: {file: gnss_1730.ubx, time_axis: gpst_unix}
    imu: {file: imu.csv, format: <a registered IMU format> | column-map fields}   # optional
    filter: {...}                  # with an IMU: config (state_blocks with clk), sources, initial_state

The IMU, when given, is a column map (``core/importer/columns.py``) on the
same time axis as the GNSS stamps; ``filter.initial_state`` fields not given
(position, receiver clock bias and drift, inter-system biases) come from a
single-point solution of the first receiver epochs; ``imu.format`` names an entry of
:data:`IMU_FORMATS` (a function spec -> column map) registered by the module
that knows that sensor's file. Without an IMU the bag holds the receiver
data only (single-point positioning, ``player``) and no filter.yaml is
written. The default sources of these presets: ``imu/data_raw`` (imu) and
``gnss/raw`` (gnss_raw, tightly coupled).
The first IMU record only starts the time line (its interval is unknown);
the initial state is at its epoch unless ``initial_state.t_s`` says otherwise.

No attitude in ``filter.initial_state`` (and no truth file): the filter
aligns on the data (``hyper_nav_filter.core.alignment``): levelling on the
first ``alignment.window_s`` seconds, heading by gyrocompassing where the
IMU grade (the filter block's bias sigmas) allows, else from the first GNSS
velocity above ``alignment.speed_threshold_mps`` (receiver presets: this
project's single-point position + Doppler velocity; fix files: their velocity
columns); the IMU table then starts at the alignment epoch, and the
alignment's sigmas become ``init_att_sigma_arcmin``, ``init_vel_sigma_mps``
(and the gyro bias prior when it was estimated on a static window). Fields
given explicitly win. Optional ``alignment:`` block: ``window_s`` (5),
``speed_threshold_mps`` (1), ``static_speed_mps`` (0.3),
``max_gyrocompass_sigma_deg`` (3), ``course_sigma_deg`` (0). The IMU block's
``mounting`` and ``antenna_lever_arm_m`` (core/importer/columns.py) are
applied in the importer; the lever arm becomes ``antenna_lever_arm_b_m``
unless the filter block sets it. ``{real_data}`` in a file path is the
shared recordings folder (``spp.default_data_dir``).
"""
from __future__ import annotations

import argparse
import copy
import pathlib
import sys

import numpy as np
import yaml

from hyper_nav_filter.core import units
from hyper_nav_filter.core.params import ConfigError, number
from hyper_nav_filter.filter_setup import FilterSetup
from hyper_nav_gnss.formats.registry import RECEIVER_FORMATS

from hyper_nav_workbench.core.bag import qos_profile
from hyper_nav_filter.core.params import suggestion
from hyper_nav_workbench.core.importer import columns, gnss_raw, kfgins, messages, rtklib_pos

# stream presets: name -> function(stream, spec, n_columns) -> column map; rtklib: the gnss stream is an
# RTKLIB .pos solution (core/importer/rtklib_pos.py, its own fields), the other streams column maps
PRESETS = {"kfgins": kfgins.preset, "rtklib": None}
# receiver presets: every registered receiver format (hyper_nav_gnss.formats.registry)
GNSS_RAW_PRESETS = tuple(RECEIVER_FORMATS)
# IMU file formats for the receiver presets: name -> function(spec) -> column map (columns.py fields)
IMU_FORMATS: dict = {}
KNOWN = {"preset", "kfgins_config", "imu", "gnss", "truth", "start_s", "end_s", "filter", "report", "alignment"}
ALIGNMENT_KNOWN = {"window_s", "speed_threshold_mps", "static_speed_mps", "max_gyrocompass_sigma_deg",
                   "course_sigma_deg"}
_ATTITUDE_FIELDS = ("q_b_enu_xyzw", "roll_pitch_heading_deg")
RAW_SOURCES = {"imu": {"type": "imu", "topic": "imu/data_raw"},
               "gnss": {"type": "gnss_raw", "topic": "gnss/raw"}}


def _merge(base: dict, over: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in (over or {}).items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else copy.deepcopy(v)
    return out


def _stream_spec(doc: dict, stream: str, base_dir: pathlib.Path) -> dict | None:
    spec = doc.get(stream)
    if spec is None:
        return None
    if not isinstance(spec, dict):
        raise ConfigError(f"{stream}: expected a mapping with at least 'file', got {spec!r}")
    preset = doc.get("preset")
    if preset is None:
        return spec
    if preset not in PRESETS:
        raise ConfigError(f"preset: unknown {preset!r}" + (f"; did you mean '{suggestion(preset, PRESETS)}'?"
                                                           if suggestion(preset, PRESETS) else "") +
                          f" (known: {', '.join(list(PRESETS) + list(GNSS_RAW_PRESETS))})")
    if PRESETS[preset] is None:
        return spec
    n_cols = columns.read_table(spec, base_dir, stream).shape[1] if stream == "gnss" else None
    return PRESETS[preset](stream, spec, n_cols)


def _real_data(doc: dict, data_dir) -> dict:
    """``{real_data}`` in a stream's file path -> the shared recordings folder
    (``data_dir``, else ``spp.default_data_dir()``)."""
    for stream in ("imu", "gnss", "truth"):
        spec = doc.get(stream)
        if isinstance(spec, dict):
            for key in ("file", "nav"):
                if isinstance(spec.get(key), str) and "{real_data}" in spec[key]:
                    from .spp import default_data_dir       # only then: the spp module costs 0.4 s to import
                    spec[key] = spec[key].replace("{real_data}", str(data_dir or default_data_dir()))
    return doc


NOISE_CHOICES = ("check", "from-data")


def load_import(path, data_dir=None, noise: str = "check") -> dict:
    """Read and check an import file: the tables (windowed) and the filter
    setup dict. ``noise``: ``check`` measures the IMU noise on the static
    intervals against the configured densities (``core/noise_check.py``,
    reported); ``from-data`` also adopts the suggested densities."""
    path = pathlib.Path(path)
    doc = yaml.safe_load(path.read_text())
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: expected a mapping")
    doc = _real_data(doc, data_dir)
    columns.check_fields(doc, KNOWN, "import")
    columns.check_fields(doc.get("report") or {}, {"skip_s"}, "report")
    base = path.parent
    if doc.get("preset") in GNSS_RAW_PRESETS:
        return load_raw_import(doc, base)
    filt = {}
    start, end = doc.get("start_s"), doc.get("end_s")
    if doc.get("kfgins_config"):
        kf_path = base / doc["kfgins_config"]
        kf = yaml.safe_load(kf_path.read_text())
        k_start, k_end = kfgins.window_of(kf)
        start = k_start if start is None else start
        end = k_end if end is None else end
        filt = kfgins.filter_block(kf)
    imu = columns.window(columns.imu_table(_stream_spec(doc, "imu", base), base), start, end)
    if len(imu.t_s) < 2:
        raise ConfigError(f"imu: fewer than 2 IMU records in the window [{start}, {end}]")
    gnss_spec = _stream_spec(doc, "gnss", base)
    notes = []
    gnss = None
    if gnss_spec:
        if doc.get("preset") == "rtklib":
            gnss, text = rtklib_pos.fix_table(gnss_spec, base, "gnss")
            notes.append(text)
        else:
            gnss = columns.fix_table(gnss_spec, base, "gnss")
        check_overlap(imu.t_s, gnss.t_s)
        gnss = columns.window(gnss, imu.t_s[0], end)
    if gnss is not None and gnss.pos_sigma_enu_m is None:
        raise ConfigError("gnss.sigma: required (position 1-sigma per axis)")
    truth_spec = _stream_spec(doc, "truth", base)
    truth = columns.window(columns.fix_table(truth_spec, base, "truth"), imu.t_s[0], end) if truth_spec else None
    if truth is not None and (truth.vel_enu_mps is None or truth.rph_rad is None):
        raise ConfigError("truth: needs velocity and attitude columns")
    filt = _merge(filt, doc.get("filter") or {})
    _mounting_to_config(imu, filt)
    noise_report = noise_check_of(imu, gnss, filt, doc.get("alignment"), noise)
    init = dict(filt.get("initial_state") or {})
    if not init and truth is not None:
        init = initial_from_truth(truth, imu.t_s[0])
    elif not any(k in init for k in _ATTITUDE_FIELDS):         # no truth, no attitude: align on the data
        if gnss is None or gnss.vel_enu_mps is None:
            if not init:
                raise ConfigError("filter.initial_state: required when no truth file is given")
        else:
            al = align_on_data(imu, gnss.t_s, gnss.vel_enu_mps, gnss.vel_sigma_enu_mps, float(gnss.lat_rad[0]),
                               float(gnss.alt_m[0]), filt, doc.get("alignment"))
            imu = columns.window(imu, al.t_s, end)
            k = int(np.argmin(np.abs(gnss.t_s - al.t_s)))
            init = {"lat_deg": float(np.rad2deg(gnss.lat_rad[k])), "lon_deg": float(np.rad2deg(gnss.lon_rad[k])),
                    "alt_m": float(gnss.alt_m[k]), **_apply_alignment(al, filt, init)}
    init.setdefault("t_s", float(imu.t_s[0]))
    filt["initial_state"] = init
    setup = {"filter": filt, "report": {"skip_s": 0.0, **(doc.get("report") or {})}}
    FilterSetup.from_dict(_plain(setup))                     # validate now, naming the field
    return {"imu": imu, "gnss": gnss, "truth": truth, "setup": _plain(setup), "window": (start, end), "notes": notes,
            "noise_check": noise_report}


def noise_check_of(imu, gnss, filt: dict, alignment_spec, noise: str = "check"):
    """The IMU noise check (``core/noise_check.py``) of an imported table on
    its static intervals (the alignment window, GNSS-static runs), against
    the filter block's densities; with ``noise == 'from-data'`` the
    suggestion replaces them in ``filt`` (aliases of the two fields dropped).
    None when no static interval holds data."""
    from hyper_nav_filter.core.config import PARAM_BY_NAME, FilterConfig

    from hyper_nav_workbench.core import noise_check
    if noise not in NOISE_CHOICES:
        raise ConfigError(f"--noise: unknown {noise!r} (known: {', '.join(NOISE_CHOICES)})")
    spec = _alignment_spec(alignment_spec)
    cfg = FilterConfig.from_dict(dict(filt.get("config") or {}))
    dt = np.diff(imu.t_s)
    t = imu.t_s[1:]
    iv = noise_check.static_intervals(t, spec.get("window_s", 5.0), None if gnss is None else gnss.t_s,
                                      None if gnss is None else gnss.vel_enu_mps, spec.get("static_speed_mps", 0.3))
    chk = noise_check.check(t, imu.dtheta_b_rad[1:] / dt[:, None], imu.dvel_b_mps[1:] / dt[:, None], cfg, iv)
    if chk is not None and noise == "from-data":
        c = filt.setdefault("config", {})
        for name, value in chk.suggested().items():
            for alias in [name] + [a.name for a in PARAM_BY_NAME[name].aliases]:
                c.pop(alias, None)
            c[name] = value
        chk.notes.append("adopted (--noise from-data): the suggested densities are in filter.yaml")
    return chk


def check_overlap(imu_t_s, gnss_t_s) -> None:
    """ConfigError when the IMU and GNSS time axes do not overlap: a counter
    given as a time, seconds of week against continuous GPST, ms against s."""
    i0, i1, g0, g1 = float(imu_t_s[0]), float(imu_t_s[-1]), float(gnss_t_s[0]), float(gnss_t_s[-1])
    if i1 < g0 or g1 < i0:
        gap = g0 - i1 if i1 < g0 else i0 - g1
        hint = []
        if abs(gap) > 1e8:
            hint.append("one looks like continuous GPST (~1e9 s), the other not: seconds of week, or a counter "
                        "(imu.time.tag / imu.time.map)?")
        elif max(i1, g1) < 604800.0 * 1.01 and min(i0, g0) > 0 and abs(gap) < 604800.0:
            hint.append("a constant offset (imu.time.offset_s) or a unit (imu.time.unit)?")
        raise ConfigError(f"imu.time and gnss.time: disjoint time axes: IMU {i0:.3f} to {i1:.3f} s, GNSS {g0:.3f} to "
                          f"{g1:.3f} s ({gap:.3f} s apart)" + (f"; {hint[0]}" if hint else ""))


def _imu_spec(spec, where="imu") -> dict:
    if not isinstance(spec, dict):
        raise ConfigError(f"{where}: expected a mapping with at least 'file', got {spec!r}")
    fmt = spec.get("format")
    if fmt is None:
        return spec
    if fmt not in IMU_FORMATS:
        raise ConfigError(f"{where}.format: unknown {fmt!r} (known: {', '.join(IMU_FORMATS) or 'none registered'})")
    return IMU_FORMATS[fmt]({k: v for k, v in spec.items() if k != "format"})


def load_raw_import(doc: dict, base: pathlib.Path) -> dict:
    """A ``ubx`` / ``rinex`` import: receiver data (+ optional IMU and filter setup)."""
    if "truth" in doc or "kfgins_config" in doc:
        bad = "truth" if "truth" in doc else "kfgins_config"
        raise ConfigError(f"{bad}: not used by preset {doc['preset']!r}")
    if not isinstance(doc.get("gnss"), dict):
        raise ConfigError("gnss: required (a mapping with at least 'file')")
    spec = dict(doc["gnss"])
    start, end = doc.get("start_s", spec.pop("start_s", None)), doc.get("end_s", spec.pop("end_s", None))
    gnss = gnss_raw.window(gnss_raw.read_gnss(doc["preset"], spec, base), start, end)
    imu = None
    if doc.get("imu") is not None:
        imu = columns.window(columns.imu_table(_imu_spec(doc["imu"]), base), start, end)
        if len(imu.t_s) < 2:
            raise ConfigError(f"imu: fewer than 2 IMU records in the window [{start}, {end}]")
    setup = None
    alignment = None
    if imu is not None:
        filt = copy.deepcopy(doc.get("filter") or {})
        filt.setdefault("config", {}).setdefault("state_blocks", ["att", "vel", "pos", "bg", "ba", "clk"])
        filt.setdefault("sources", copy.deepcopy(RAW_SOURCES))
        _mounting_to_config(imu, filt)
        init = dict(filt.get("initial_state") or {})
        if not any(k in init for k in _ATTITUDE_FIELDS):       # no attitude given: align on the data
            a_spec = _alignment_spec(doc.get("alignment"))
            t0 = float(imu.t_s[0])
            fixes = gnss_raw.spp_fixes(gnss, t0 - 1.0, t0 + a_spec.get("window_s", 5.0) + 120.0)
            al = align_on_data(imu, fixes.t_s, fixes.vel_enu_mps, np.sqrt(np.einsum("kii->ki", fixes.vel_cov_enu_m2ps2)),
                               float(fixes.lat_rad[0]), float(fixes.alt_m[0]), filt, a_spec)
            imu = columns.window(imu, al.t_s, end)        # the alignment epoch starts the time line
            init = _apply_alignment(al, filt, init)
            alignment = al
        init.setdefault("t_s", float(imu.t_s[0]))
        if "lat_deg" not in init:                 # position, clock, inter-system biases from SPP
            init = {**gnss_raw.initial_from_spp(gnss, init["t_s"]), **init}
        filt["initial_state"] = init
        setup = _plain({"filter": filt, "report": {"skip_s": 0.0, **(doc.get("report") or {})}})
        FilterSetup.from_dict(setup)
    elif doc.get("filter"):
        raise ConfigError("filter: needs an imu block (the filter is driven by the IMU)")
    return {"imu": imu, "gnss": None, "truth": None, "gnss_raw": gnss, "setup": setup, "window": (start, end),
            "alignment": alignment}


def _alignment_spec(spec) -> dict:
    spec = dict(spec or {})
    columns.check_fields(spec, ALIGNMENT_KNOWN, "alignment")
    for k, v in spec.items():
        number(f"alignment.{k}", v, 0.0)
    return spec


def _mounting_to_config(imu, filt: dict) -> None:
    """The IMU block's antenna lever arm as the filter's, unless the filter block sets one."""
    if imu.antenna_lever_arm_b_m is not None:
        filt.setdefault("config", {}).setdefault("antenna_lever_arm_b_m", list(imu.antenna_lever_arm_b_m))


def imu_grade(config: dict):
    """``core.alignment.ImuGrade`` of a filter config block (its declared
    bias sigmas: the initial ones when set, else the steady-state ones; ARW, VRW)."""
    from hyper_nav_filter.core import units
    from hyper_nav_filter.core.alignment import ImuGrade
    from hyper_nav_filter.core.config import FilterConfig
    c = FilterConfig.from_dict({k: v for k, v in (config or {}).items()})
    ba = np.asarray(c.init_accel_bias_sigma_ug, float)
    ba = np.asarray(c.accel_bias_sigma_ug, float) if np.all(np.isnan(ba)) else ba
    bg = np.asarray(c.init_gyro_bias_sigma_deg_per_hr, float)
    bg = np.asarray(c.gyro_bias_sigma_deg_per_hr, float) if np.all(np.isnan(bg)) else bg
    return ImuGrade(float(np.max(units.ug(ba))), float(np.max(units.deg_per_hr(bg))),
                    float(np.max(units.deg_per_sqrt_hr(c.gyro_arw_deg_per_sqrt_hr))),
                    float(np.max(units.ug_per_sqrt_hz(c.accel_vrw_ug_per_sqrt_hz))))


def align_on_data(imu, gnss_t_s, gnss_vel_enu_mps, gnss_vel_sigma_mps, lat_rad: float, alt_m: float, filt: dict,
                  spec=None):
    """``core.alignment.align`` on an imported IMU table (mean rates =
    increments / stamp intervals; row 0 only starts the time line) and GNSS
    velocities, with the IMU grade of the filter block."""
    from hyper_nav_filter.core.alignment import AlignmentError, align
    dt = np.diff(imu.t_s)
    try:
        return align(imu.t_s[1:], imu.dtheta_b_rad[1:] / dt[:, None], imu.dvel_b_mps[1:] / dt[:, None], lat_rad,
                     alt_m, imu_grade(filt.get("config")), gnss_t_s, gnss_vel_enu_mps, gnss_vel_sigma_mps,
                     **_alignment_spec(spec))
    except AlignmentError as exc:
        raise ConfigError(f"filter.initial_state: no attitude given and {exc}") from None


def _apply_alignment(al, filt: dict, init: dict) -> dict:
    """The alignment's initial state under the explicitly given fields, and
    its prior sigmas under the explicitly given config fields; a gyro bias
    estimated on a static window replaces the declared (turn-on) prior sigma,
    which served as the IMU grade."""
    from hyper_nav_filter.core.config import PARAM_BY_NAME
    from hyper_nav_filter.core.initial_state import INIT_BY_NAME
    cfg = filt.setdefault("config", {})
    for k, v in al.config_fields().items():
        if not ({k} | {a.name for a in PARAM_BY_NAME[k].aliases}) & set(cfg):
            cfg[k] = v
    if al.method == "gnss_velocity" and al.static:    # the bias was estimated on the static window: its sigma
        for name in ["init_gyro_bias_sigma_deg_per_hr"] + [a.name for a in
                                                              PARAM_BY_NAME["init_gyro_bias_sigma_deg_per_hr"].aliases]:
            cfg.pop(name, None)
        cfg["init_gyro_bias_sigma_deg_per_hr"] = al.config_fields()["init_gyro_bias_sigma_deg_per_hr"]
    if "t_s" in init and abs(float(init["t_s"]) - al.t_s) > 1e-6:
        raise ConfigError(f"filter.initial_state.t_s: given ({init['t_s']}) without an attitude, but the alignment "
                          f"holds at {al.t_s!r}: give the attitude too, or leave t_s out")
    out = dict(init)
    for k, v in al.initial_state_fields().items():
        if not ({k} | {a.name for a in INIT_BY_NAME[k].aliases}) & set(init):
            out[k] = v
    return out


def initial_from_truth(truth, t_s: float) -> dict:
    """The truth row at (or just before) t_s as initial_state fields."""
    k = max(0, int(np.searchsorted(truth.t_s, t_s + 1e-6)) - 1)
    return {"t_s": float(t_s), "lat_deg": float(np.rad2deg(truth.lat_rad[k])),
            "lon_deg": float(np.rad2deg(truth.lon_rad[k])), "alt_m": float(truth.alt_m[k]),
            "vel_enu_mps": [float(x) for x in truth.vel_enu_mps[k]],
            "roll_pitch_heading_deg": [float(x) for x in np.rad2deg(truth.rph_rad[k])]}


def _plain(x):
    """numpy scalars/arrays -> plain Python (YAML-safe)."""
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [_plain(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    return x


def write(imported: dict, out, per_message: bool = False) -> dict:
    """The bag and its filter.yaml; returns the message counts per topic.
    The messages are built and written as arrays (``bag_arrays.write_arrays``);
    ``per_message`` takes the reference path (one message object each,
    ``bag.BagWriter``): the same messages, written 10-20x slower."""
    out = pathlib.Path(out)
    if imported.get("gnss_raw") is not None:
        return write_raw(imported, out)
    setup = FilterSetup.from_dict(imported["setup"])
    imu, gnss, truth = imported["imu"], imported["gnss"], imported["truth"]
    dt = float(np.median(np.diff(imu.t_s)))
    cfg = setup.config
    gyro_var = units.deg_per_sqrt_hr(cfg.gyro_arw_deg_per_sqrt_hr) ** 2 / dt
    accel_var = units.ug_per_sqrt_hz(cfg.accel_vrw_ug_per_sqrt_hz) ** 2 / dt
    if per_message:
        streams = {"/imu/data_raw": ("sensor_msgs/msg/Imu", messages.imu_messages(imu, gyro_var, accel_var))}
        if gnss is not None:
            streams["/gnss/fix"] = ("sensor_msgs/msg/NavSatFix", messages.fix_messages(gnss))
            if gnss.vel_enu_mps is not None and gnss.vel_sigma_enu_mps is not None:
                streams["/gnss/vel"] = ("geometry_msgs/msg/TwistWithCovarianceStamped", messages.vel_messages(gnss))
        if truth is not None:
            streams["/truth/state"] = ("hyper_nav_msgs/msg/NavState", messages.truth_messages(truth))
        counts = messages.write_bag(out, streams)
    else:
        from hyper_nav_workbench.core.bag_arrays import write_arrays
        from hyper_nav_workbench.core.importer import bag_columns as bc
        topics = {"/imu/data_raw": bc.imu_columns(imu, gyro_var, accel_var)}
        if gnss is not None:
            topics["/gnss/fix"] = bc.fix_columns(gnss)
            if gnss.vel_enu_mps is not None and gnss.vel_sigma_enu_mps is not None:
                topics["/gnss/vel"] = bc.vel_columns(gnss)
        if truth is not None:
            topics["/truth/state"] = bc.truth_columns(truth)
        counts = write_arrays(out, topics)
    (out / "filter.yaml").write_text(yaml.safe_dump(imported["setup"], sort_keys=False))
    if imported.get("noise_check") is not None:
        (out / NOISE_FILE).write_text(yaml.safe_dump(_plain(imported["noise_check"].as_dict()), sort_keys=False))
    return counts


NOISE_FILE = "noise_check.yaml"          # beside filter.yaml: the import's IMU noise check, shown by replay_filter


def write_raw(imported: dict, out: pathlib.Path) -> dict:
    """The bag of a receiver import (gnss/raw, gnss/ephemeris, imu/data_raw) and,
    with an IMU, its filter.yaml; returns the message counts per topic."""
    g = imported["gnss_raw"]
    # ephemerides first: at equal stamps a record is written before the epoch that needs it
    streams = {"/gnss/ephemeris": ("hyper_nav_msgs/msg/GnssEphemeris", gnss_raw.ephemeris_messages(g, g.counts)),
               "/gnss/raw": ("hyper_nav_msgs/msg/GnssMeasurements", gnss_raw.raw_messages(g, counts=g.counts))}
    imu = imported["imu"]
    if imu is not None:
        setup = FilterSetup.from_dict(imported["setup"])
        cfg = setup.config
        dt = float(np.median(np.diff(imu.t_s)))
        gyro_var = units.deg_per_sqrt_hr(cfg.gyro_arw_deg_per_sqrt_hr) ** 2 / dt
        accel_var = units.ug_per_sqrt_hz(cfg.accel_vrw_ug_per_sqrt_hz) ** 2 / dt
        streams["/imu/data_raw"] = ("sensor_msgs/msg/Imu", messages.imu_messages(imu, gyro_var, accel_var))
    qos = {"/gnss/ephemeris": [qos_profile(durability="transient_local", depth=1000)]}
    counts = messages.write_bag(out, streams, qos)
    if imported["setup"] is not None:
        (out / "filter.yaml").write_text(yaml.safe_dump(imported["setup"], sort_keys=False))
    return counts


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="import_data", description=__doc__.split("\n\n")[0])
    ap.add_argument("import_file", help="import description (YAML), see the module docstring")
    ap.add_argument("--out", required=True, help="bag directory to create (must not exist)")
    ap.add_argument("--noise", choices=NOISE_CHOICES, default="check",
                    help="check: report the IMU noise measured on the static intervals against the configured "
                         "densities (core/noise_check.py); from-data: also adopt the suggested densities "
                         "(per axis max(configured, measured))")
    args = ap.parse_args(argv)
    try:
        imported = load_import(args.import_file, noise=args.noise)
        counts = write(imported, args.out)
    except (ConfigError, FileExistsError, ValueError, OSError) as exc:
        print(f"import_data: error: {exc}", file=sys.stderr)
        return 2
    g = imported.get("gnss_raw")
    if g is not None:
        t0, t1 = g.stamp_s(g.epochs[0].t_rx_gpst_s), g.stamp_s(g.epochs[-1].t_rx_gpst_s)
        print(f"[import_data] {g.source}: read in {g.read_wall_s:.2f} s wall; {len(g.epochs)} receiver epochs, "
              f"{t1 - t0:.1f} s from stamp {t0:.3f} s; "
              + ", ".join(f"{k} {v}" for k, v in sorted(g.counts.items())))
        for e in g.errors[:5]:
            print(f"[import_data] skipped: {e}")
    for text in imported.get("notes", ()):
        print(f"[import_data] {text}")
    chk = imported.get("noise_check")
    if chk is not None:
        print("[import_data] " + chk.describe().replace("\n", "\n[import_data] "))
    elif imported.get("gnss_raw") is None and imported["imu"] is not None:
        print("[import_data] IMU noise: not measured (no static interval: the alignment window moves and no GNSS "
              "standstill of 2 s or more); the configured densities are unchecked")
    imu = imported["imu"]
    if imu is not None:
        span = imu.t_s[-1] - imu.t_s[0]
        print(f"[import_data] imu: {span:.1f} s of data from t = {imu.t_s[0]:.3f} s; its axes in the body "
              f"(scenario imu.mounting_b_xyzw, on /tf_static): {[round(v, 9) for v in imu.mounting_b_xyzw]}")
    print(f"[import_data] {args.out}: " + ", ".join(f"{t} {n}" for t, n in counts.items()))
    if imported["setup"] is not None:
        print(f"[import_data] filter setup: {pathlib.Path(args.out) / 'filter.yaml'}; "
              f"replay: ros2run hyper_nav_workbench replay_filter {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
