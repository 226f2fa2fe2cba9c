"""Checks of a recorded run that decide the report's verdict (pure Python).

A run passes only if nothing was lost and nothing stopped:

* ``epoch_check``: every solution epoch the scenario promises (the filter
  releases the first IMU epoch at or after each multiple of
  1/output_rate_hz, exactly as ``FusionEngine.release`` does; those with a
  truth epoch) is in the run, from the start (a gap before the accuracy
  window is lost data too), with the missing ones grouped into gaps;
* ``delivery_rows``: per topic, what its publisher counted, what the bag
  holds, and, for the fusion node's inputs, what fusion received and
  processed (``received <topic>``, ``processed <topic>`` on its status);
* ``schedule_rows``: every sensor published its whole stream (``scheduled
  <topic>`` against ``published <topic>``);
* ``status_faults``: what went WARN/ERROR on /diagnostics, when, and whether
  it recovered (the liveness monitor's node and stream verdicts included);
* accuracy limits, as before.

Each check returns rows and a list of failure sentences; ``verdict`` joins them.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

FUSION_NODE = "fusion"
MONITOR_PREFIX = "hyper_nav_sim: monitor: "
LEVEL_NAMES = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}


@dataclass
class Outcome:
    """Result of the checks: failure and warning sentences, and the details."""
    failures: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    details: dict = field(default_factory=dict)

    @property
    def verdict(self) -> str:
        return "FAIL" if self.failures else "PASS"


# ---- solution epochs -------------------------------------------------------------
def release_epochs(imu_t_s, output_rate_hz: float, t0_s: float = 0.0) -> np.ndarray:
    """Epochs the fusion engine releases from IMU epochs ``imu_t_s``: the
    first IMU epoch at or after each multiple of 1/output_rate_hz from t0
    (``FusionEngine.release``)."""
    out, next_t, step = [], t0_s, 1.0 / output_rate_hz
    for t in np.asarray(imu_t_s, float):
        if t < next_t - 1e-9:
            continue
        out.append(t)
        while next_t <= t + 1e-9:
            next_t += step
    return np.array(out)


def expected_scored_epochs(duration_s: float, imu_rate_hz: float, output_rate_hz: float,
                           truth_rate_hz: float, skip_s: float) -> np.ndarray:
    """Solution epochs that must be scored: released epochs that have a truth
    epoch (matched to 1 us), from skip_s to the end of the scenario."""
    n_imu = int(np.floor(duration_s * imu_rate_hz + 1e-9))
    released = release_epochs(np.arange(1, n_imu + 1) / imu_rate_hz, output_rate_hz)
    n_truth = int(np.floor(duration_s * truth_rate_hz + 1e-9))
    truth = {round(k / truth_rate_hz * 1e6) for k in range(n_truth + 1)}
    keep = [t for t in released if t >= skip_s - 1e-9 and round(t * 1e6) in truth]
    return np.array(keep)


def epoch_check(scored_t_s, expected_t_s, out: Outcome, max_gaps: int = 5) -> dict:
    """Compare the scored epochs with the expected ones; missing epochs are
    grouped into gaps (runs of consecutive expected epochs)."""
    scored = {round(t * 1e6) for t in np.asarray(scored_t_s, float)}
    expected = np.asarray(expected_t_s, float)
    missing = np.array([round(t * 1e6) not in scored for t in expected], bool)
    gaps = []
    k = 0
    while k < len(expected):
        if missing[k]:
            j = k
            while j + 1 < len(expected) and missing[j + 1]:
                j += 1
            gaps.append((float(expected[k]), float(expected[j]), j - k + 1))
            k = j + 1
        else:
            k += 1
    d = {"expected": int(len(expected)), "scored": int(len(expected) - missing.sum()),
         "missing": int(missing.sum()), "gaps": [{"from_s": a, "to_s": b, "epochs": n} for a, b, n in gaps]}
    if gaps:
        worst = sorted(gaps, key=lambda g: -g[2])[:max_gaps]
        text = ", ".join(f"{a:.2f}-{b:.2f} s ({n})" for a, b, n in worst)
        more = f" and {len(gaps) - max_gaps} more" if len(gaps) > max_gaps else ""
        out.failures.append(f"epochs: {d['scored']} of {d['expected']} expected solution epochs present; "
                            f"{d['missing']} missing in {len(gaps)} gap(s): {text}{more}")
    out.details["epochs"] = d
    return d


# ---- counts ------------------------------------------------------------------------
def _topic(key: str) -> str:
    return key.split(" ", 1)[1].lstrip("/")


def delivery_rows(last_values: dict, recorded: dict, out: Outcome, dead: set | frozenset = frozenset()) -> dict:
    """Per topic: published (its publisher's ``published <topic>``), recorded
    (the bag), and for fusion's inputs received / processed (its ``received``
    and ``processed`` counters). Fails on any published != recorded,
    published != received or received != processed. A node in ``dead``
    (killed) could not report its last counts: its counters are a lower
    bound, so only a shortfall downstream of it is a loss."""
    recorded = {t.lstrip("/"): int(n) for t, n in recorded.items()}
    rows: dict[str, dict] = {}
    for node, values in last_values.items():
        for key, val in values.items():
            kind = key.split(" ", 1)[0]
            if kind not in ("published", "received", "processed") or " " not in key:
                continue
            row = rows.setdefault(_topic(key), {})
            if kind == "published":
                row["published"], row["publisher"] = int(val), node
            else:
                row[f"{kind}_by_{node}"] = int(val)
    for topic, row in rows.items():
        row["recorded"] = recorded.get(topic, 0)
        pub, pub_dead = row.get("published"), row.get("publisher") in dead
        if pub is not None and (pub > row["recorded"] or (pub != row["recorded"] and not pub_dead)):
            out.failures.append(f"delivery: {topic}: published {pub}, recorded {row['recorded']} "
                                f"({pub - row['recorded']:+d} between publisher and recorder)")
        for key in [k for k in row if k.startswith("received_by_")]:
            node = key[len("received_by_"):]
            if node in dead:
                out.warnings.append(f"inputs: {topic}: {node} died; its counts end at its last status "
                                    f"(received {row[key]})")
                continue
            if pub is not None and (pub > row[key] or (pub != row[key] and not pub_dead)):
                out.failures.append(f"inputs: {topic}: published {pub}, received by {node} {row[key]} "
                                    f"({pub - row[key]:+d} on the way to {node})")
            proc = row.get(f"processed_by_{node}")
            if proc is not None and proc != row[key]:
                out.failures.append(f"inputs: {topic}: received by {node} {row[key]}, processed {proc} "
                                    f"({row[key] - proc} not used: rejected or dropped)")
    out.details["delivery"] = rows
    return rows


def delivery_losses(rows: dict) -> list[str]:
    """The topics of ``delivery_rows`` where a count differs along the way
    (published, recorded, received and processed by each consumer)."""
    lost = []
    for topic, row in sorted(rows.items()):
        counts = [row[k] for k in row if k == "recorded" or k.startswith(("received_by_", "processed_by_"))]
        if "published" in row:
            counts.append(row["published"])
        if len(set(counts)) > 1:
            lost.append(topic)
    return lost


def rejected_inputs(fusion_values: dict, out: Outcome) -> dict:
    """Fusion's ``rejected_*`` counters (NaN, out of order, stale, gap,
    malformed): any rejected input message fails the run."""
    rej = {k: int(v) for k, v in fusion_values.items() if k.startswith("rejected_") and str(v).lstrip("-").isdigit()}
    bad = {k: v for k, v in rej.items() if v}
    if bad:
        out.failures.append("inputs: fusion rejected input messages: " +
                            ", ".join(f"{k[len('rejected_'):]} {v}" for k, v in sorted(bad.items())))
    out.details["rejected"] = rej
    return rej


def bridged_gaps(fusion_values: dict, out: Outcome) -> int:
    """IMU gaps the fusion engine bridged (``imu_gaps``, ``imu_gap_total_s``):
    its solutions there come from interpolated rates, not from measured data."""
    n = int(float(fusion_values.get("imu_gaps", 0) or 0))
    if n:
        out.failures.append(f"inputs: fusion bridged {n} IMU gap(s), "
                            f"{float(fusion_values.get('imu_gap_total_s', 0) or 0):.2f} s without IMU data")
    out.details["imu_gaps"] = n
    return n


def schedule_rows(last_values: dict, out: Outcome) -> dict:
    """A sensor that published less than its whole stream stopped early."""
    rows = {}
    for node, values in last_values.items():
        for key, val in values.items():
            if key.startswith("scheduled "):
                topic = _topic(key)
                pub = int(values.get(f"published {topic}", 0))
                rows[topic] = {"node": node, "scheduled": int(val), "published": pub}
                if pub < int(val):
                    out.failures.append(f"streams: {node} published {pub} of the {val} {topic} messages "
                                        f"of its scenario (stopped early)")
    out.details["schedule"] = rows
    return rows


def input_truncated(last_values: dict, out: Outcome) -> None:
    """A player that replayed a truncated bag says so (``truncated: yes``):
    the run did not see all of its input."""
    for node, values in last_values.items():
        if str(values.get("truncated", "")).lower() == "yes":
            out.failures.append(f"bag: {node} replayed a truncated bag: {values.get('bag_error', '')}")


# ---- /diagnostics timeline -------------------------------------------------------------
def level_of(raw) -> int:
    """DiagnosticStatus.level from a deserialized message (int or 1-byte bytes)."""
    return raw[0] if isinstance(raw, (bytes, bytearray)) else int(raw)


def status_faults(timeline: dict, out: Outcome, exits: list | None = None) -> list[dict]:
    """Every status name that went WARN or ERROR: first time, level, message,
    and whether it was OK again at the end. ``timeline``: name -> list of
    (t_s, level, message, values) in time order. ERROR that did not recover
    fails; a dead node (process exit recorded by run_graph, ``exits``) fails
    with its exit status and the monitor's time of its last heartbeat."""
    faults = []
    for name, events in timeline.items():
        if name == MONITOR_PREFIX.rstrip(": "):        # the monitor's summary repeats its verdicts
            continue
        bad = [e for e in events if e[1] in (1, 2)]
        if not bad:
            continue
        first = bad[0]
        last = events[-1]
        worst = max(e[1] for e in bad)
        since = first[3].get("since_t_s") or ""
        t_first = float(since) if since else first[0]
        faults.append({"name": name, "level": LEVEL_NAMES[worst], "first_t_s": t_first,
                       "first_message": first[2], "last_level": LEVEL_NAMES.get(last[1], str(last[1])),
                       "last_message": last[2], "recovered": last[1] == 0})
    dead = {e["ros_name"]: e for e in (exits or [])}
    for f in faults:
        node = f["name"][len(MONITOR_PREFIX) + len("node "):] if f["name"].startswith(MONITOR_PREFIX + "node ") else None
        text = f"{f['name'].replace(MONITOR_PREFIX, 'monitor: ')}: {f['level']} from t = {f['first_t_s']:.1f} s: " \
               f"{f['first_message']}" + (" (recovered)" if f["recovered"] else "")
        if node in dead:
            e = dead.pop(node)
            out.failures.append(f"nodes: '{node}' died ({e['how']}) {e['t_wall_s']:.1f} s after the start "
                                f"(wall); last heartbeat at t = {f['first_t_s']:.1f} s")
        elif f["level"] == "ERROR" and not f["recovered"]:
            out.failures.append(text)
        else:
            out.warnings.append(text)
    for node, e in dead.items():
        out.failures.append(f"nodes: '{node}' died ({e['how']}) {e['t_wall_s']:.1f} s after the start (wall)")
    out.details["diagnostics_faults"] = faults
    return faults
