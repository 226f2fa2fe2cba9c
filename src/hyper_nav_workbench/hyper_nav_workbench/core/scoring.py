"""Scoring a navigation solution against the truth (no ROS): the one place
where estimate-minus-truth errors are computed, summarized, held against
the scenario's limits and turned into a verdict. ``report`` and
``replay_filter`` (recorded runs), Monte Carlo (``core.montecarlo``), the
importer (``core.importer.score``), ``offline_fly``, the reproductions and
the live view (``core.live_view``) all score through it.

States are dicts of arrays with one row per epoch::

    {"t": (N,) s, "lat": (N,) rad, "lon": (N,) rad, "alt": (N,) m,
     "vel": (N, 3) ENU m/s, "C": (N, 3, 3) C_b_n (body FLU -> ENU)}

from NavState messages (``states_from_msgs``), fusion-core solutions
(``states_from_solutions``) or a trajectory's truth (``states_from_truth``).
Errors (``state_errors``, estimate - truth): position in local ENU metres
about the truth (``earth.position_error_enu_m``, longitude difference
wrapped), velocity in ENU m/s, attitude the small-angle phi in ENU with
C_est = (I - [phi x]) C_true (``attitude.attitude_error_n_rad``), in degrees.

The verdict: checks append to a ``run_check.Outcome`` (failures, warnings,
details); ``verdict`` prints them and the one ``VERDICT: PASS|FAIL`` line
and gives the exit code.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from hyper_nav_filter.conversions import stamp_to_s
from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import quat_xyzw_to_C

from hyper_nav_workbench.core import run_check

ERROR_KEYS = ("pos_enu_m", "vel_enu_mps", "att_enu_deg")


class ScoringError(Exception):
    """No score can be made (the commands exit 2); the message says why."""


# ---- states -------------------------------------------------------------------------------
def states_from_msgs(msgs) -> dict:
    """States of NavState messages (rclpy or rosbags, duck-typed)."""
    return {"t": np.array([stamp_to_s(m.header.stamp) for m in msgs]),
            "lat": np.array([m.lat_rad for m in msgs]), "lon": np.array([m.lon_rad for m in msgs]),
            "alt": np.array([m.alt_m for m in msgs]),
            "vel": np.array([np.asarray(m.vel_enu_mps, float) for m in msgs]).reshape(-1, 3),
            "C": np.array([quat_xyzw_to_C([m.q_b_enu.x, m.q_b_enu.y, m.q_b_enu.z, m.q_b_enu.w])
                           for m in msgs]).reshape(-1, 3, 3)}


def states_from_solutions(sols) -> dict:
    """States of the fusion core's released solutions (``core.fusion.Solution``):
    read from their snapshots at once where the frame allows
    (``fusion.solution_arrays``, the same numbers), else one ``.state`` each."""
    from hyper_nav_filter.core.fusion import solution_arrays
    arrays = solution_arrays(sols)
    if arrays is not None:
        return arrays
    return {"t": np.array([s.t_s for s in sols]), "lat": np.array([s.state.lat_rad for s in sols]),
            "lon": np.array([s.state.lon_rad for s in sols]), "alt": np.array([s.state.alt_m for s in sols]),
            "vel": np.array([s.state.vel_enu_mps for s in sols]).reshape(-1, 3),
            "C": np.array([s.state.C_b_n for s in sols]).reshape(-1, 3, 3)}


def states_from_truth(tr) -> dict:
    """States of a trajectory's truth (``Trajectory.truth(t)``, a ``TruthSample``)."""
    return {"t": np.asarray(tr.t_s, float), "lat": np.asarray(tr.lat_rad, float),
            "lon": np.asarray(tr.lon_rad, float), "alt": np.asarray(tr.alt_m, float),
            "vel": np.asarray(tr.vel_enu_mps, float).reshape(-1, 3), "C": np.asarray(tr.C_b_n).reshape(-1, 3, 3)}


# ---- errors -------------------------------------------------------------------------------
def state_errors(nav: dict, truth: dict, attitude: bool = True) -> dict:
    """Estimate - truth of two state sets at the same epochs (row by row):
    {"t", "pos_enu_m" (N, 3), "vel_enu_mps" (N, 3), "att_enu_deg" (N, 3)}
    (``attitude`` False: without "att_enu_deg", for a caller that needs
    position and velocity only: the rotations are most of the cost)."""
    pos = earth.position_error_enu_m(nav["lat"], nav["lon"], nav["alt"], truth["lat"], truth["lon"], truth["alt"])
    vel = nav["vel"] - truth["vel"]
    out = {"t": nav["t"], "pos_enu_m": np.asarray(pos).reshape(-1, 3), "vel_enu_mps": vel}
    if attitude:
        # attitude_error_n_rad for every row: the rotation vector of C_true C_est^T
        att = Rotation.from_matrix(truth["C"] @ np.swapaxes(nav["C"], -1, -2)).as_rotvec() if len(nav["t"]) else \
            np.zeros((0, 3))
        out["att_enu_deg"] = np.rad2deg(att)
    return out


def errors(nav: dict, truth: dict, index: bool = False, attitude: bool = True):
    """Errors (estimate - truth) at the epochs both have (matched to 1 us; a
    repeated truth epoch: its last row), in time order whatever order the
    states came in (so every figure made from them, sums included, does not
    depend on the arrival order). Pairing by sorted keys: one array operation
    (672k epochs: 0.3 s; a Python dict per epoch took 2 s). ``index``: also
    the row of ``nav`` of each error row, (errors, rows); ``attitude``: as
    in ``state_errors``."""
    kt = np.round(np.asarray(truth["t"], float) * 1e6)
    order = np.argsort(kt, kind="stable")
    ks = kt[order]
    kn = np.round(np.asarray(nav["t"], float) * 1e6)
    j = np.searchsorted(ks, kn, side="right") - 1
    found = (j >= 0) & (ks[np.clip(j, 0, None)] == kn) if len(ks) else np.zeros(len(kn), bool)
    if not found.any():
        raise ValueError("no common epochs between solution and truth")
    ni = np.flatnonzero(found)
    ti = order[j[found]]
    by_t = np.argsort(np.asarray(nav["t"], float)[ni], kind="stable")
    ni, ti = ni[by_t], ti[by_t]
    keys = nav.keys() if attitude else [k for k in nav if k != "C"]
    err = state_errors({k: nav[k][ni] for k in keys}, {k: truth[k][ti] for k in keys}, attitude)
    return (err, ni) if index else err


def solution_errors(sols, traj) -> dict:
    """Errors of fusion-core solutions against a trajectory's truth at their own epochs."""
    nav = states_from_solutions(sols)
    return state_errors(nav, states_from_truth(traj.truth(nav["t"])))


# ---- summaries, limits, the table ---------------------------------------------------------
def effective_skip_s(skip_s: float, duration_s: float) -> tuple[float, str | None]:
    """``report.skip_s``, or half the run when the run is not longer than it
    (a 20 s bag with the default 30 s window); the note says so."""
    if skip_s < duration_s:
        return skip_s, None
    eff = 0.5 * duration_s
    return eff, (f"report.skip_s = {skip_s:g} s is not inside the {duration_s:g} s run: "
                 f"scoring from t >= {eff:g} s (half the run)")


def summarize(err: dict, skip_s: float) -> dict:
    """RMS per axis, RMS 3D, max 3D and max |axis| of each error after ``skip_s``."""
    m = err["t"] >= skip_s
    if not m.any():
        raise ValueError(f"no solution epochs at or after report.skip_s = {skip_s} s "
                         f"(the run ends at {err['t'].max():.1f} s); lower it with --set report.skip_s=...")
    out = {"skip_s": skip_s, "epochs": int(m.sum())}
    for key in ERROR_KEYS:
        e = err[key][m]
        out[key] = {"rms_enu": np.sqrt(np.mean(e**2, axis=0)).tolist(),
                    "max_abs_enu": np.max(np.abs(e), axis=0).tolist(),
                    "rms_3d": float(np.sqrt(np.mean(np.sum(e**2, axis=1)))),
                    "max_3d": float(np.max(np.linalg.norm(e, axis=1)))}
    return out


def limits(sc) -> dict:
    """The scenario's accuracy limits (RMS 3D; None = no limit)."""
    return {"pos_enu_m": sc["report.max_pos_rms_m"], "vel_enu_mps": sc["report.max_vel_rms_mps"],
            "att_enu_deg": sc["report.max_att_rms_deg"]}


def reference(sc) -> dict:
    """The paper's per-axis figures the scenario names (``report.reference_*``)."""
    return {"pos_enu_m": sc["report.reference_pos_m"], "vel_enu_mps": sc["report.reference_vel_mps"],
            "att_enu_deg": sc["report.reference_att_deg"], "source": sc["report.reference_source"]}


def format_table(summary: dict, limits: dict | None = None, reference: dict | None = None) -> str:
    """Our figures, the issue's limits (3D RMS) and a paper's per-axis figures beside them."""
    names = {"pos_enu_m": ("position", "m"), "vel_enu_mps": ("velocity", "m/s"), "att_enu_deg": ("attitude", "deg")}
    ref = reference or {}
    lines = [f"accuracy after t >= {summary['skip_s']:.0f} s ({summary['epochs']} epochs)",
             f"{'':10s} {'unit':>5s} {'RMS E':>9s} {'RMS N':>9s} {'RMS U':>9s} {'RMS 3D':>9s} {'max 3D':>9s} "
             f"{'max|axis|':>9s}  {'limit RMS 3D':>14s}  {'paper/axis':>10s}"]
    for key, (label, unit) in names.items():
        s = summary[key]
        lim = (limits or {}).get(key)
        verdict = "" if lim is None else f"< {lim:<6g} {'PASS' if s['rms_3d'] < lim else 'FAIL'}"
        paper = ref.get(key)
        max_axis = max(s["max_abs_enu"])
        lines.append(f"{label:10s} {unit:>5s} " + " ".join(f"{x:9.4f}" for x in s["rms_enu"]) +
                     f" {s['rms_3d']:9.4f} {s['max_3d']:9.4f} {max_axis:9.4f}  {verdict:>14s}  "
                     + ("" if paper is None else f"< {paper:g}"))
    if ref.get("source"):
        lines.append(f"paper/axis: {ref['source']}")
    return "\n".join(lines)


# ---- checks and the verdict ---------------------------------------------------------------
def judge(err: dict, skip_s: float, limits: dict, out: run_check.Outcome) -> dict | None:
    """The summary of ``err`` after ``skip_s`` and its accuracy check against
    ``limits`` (failures into ``out``); None (and a failure) when nothing
    after ``skip_s`` can be scored."""
    try:
        summary = summarize(err, skip_s)
    except ValueError as exc:
        out.failures.append(f"accuracy: not computed: {exc}")
        return None
    for key, lim in limits.items():
        if lim is not None and not summary[key]["rms_3d"] < lim:
            out.failures.append(f"accuracy: {key} RMS 3D {summary[key]['rms_3d']:.4g} not below the limit {lim:g}")
    return summary


def expected_epochs(sc, skip_s: float, end_s: float) -> np.ndarray:
    """Solution epochs a run of the scenario must score (``run_check.expected_scored_epochs``)."""
    return run_check.expected_scored_epochs(end_s, sc["imu.rate_hz"], sc.filter_config().output_rate_hz,
                                            sc["graph.truth_rate_hz"], skip_s)


def score(nav: dict, truth: dict, sc, out: run_check.Outcome, end_s: float | None = None):
    """A solution of a scenario's run against its truth: every solution epoch
    up to ``end_s`` (default: the scenario's end) there (a gap before the
    accuracy window is lost data too), the errors, their summary after
    ``report.skip_s`` and the accuracy limits; (err, summary), or (None,
    None) when no accuracy can be computed (a failure in ``out``)."""
    if len(truth["t"]) == 0:
        raise ScoringError("no truth/state in the bag: nothing to score against")
    end_s = sc["duration_s"] if end_s is None else end_s
    skip, note = effective_skip_s(sc["report.skip_s"], end_s)
    if note:
        out.warnings.append(note)
    run_check.epoch_check(nav["t"], expected_epochs(sc, 0.0, end_s), out)
    try:
        err = errors(nav, truth)
    except ValueError as exc:
        out.failures.append(f"accuracy: not computed: {exc}")
        return None, None
    summary = judge(err, skip, limits(sc), out)
    return (err, summary) if summary is not None else (None, None)


def verdict(out: run_check.Outcome, prog: str) -> int:
    """Print the warnings, the failures and the ``VERDICT`` line; the exit code (0 PASS, 1 FAIL)."""
    for w in out.warnings:
        print(f"[{prog}] warning: {w}")
    for f in out.failures:
        print(f"[{prog}] FAIL: {f}")
    reasons = sorted({f.split(":", 1)[0] for f in out.failures})
    print(f"VERDICT: {out.verdict}" + (f" ({len(out.failures)} failure(s): {', '.join(reasons)})"
                                       if out.failures else " (nothing lost, every expected epoch scored)"))
    return 0 if out.verdict == "PASS" else 1
