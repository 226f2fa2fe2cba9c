"""Verdict rules on the filter's use of each source (pure Python): a run
whose filter refused its sources, or whose innovations disagree with their
stated noise, never passes (BRIEF: "a verdict never passes a run whose
filter diverged").

Per measurement kind (``gnss_pos``, ``gnss_vel``, ``gnss_pr`` ...) the
filter counts accepted and gated updates, the sum of NIS/dof of the accepted
ones, the innovations beyond ``FAR_SIGMA`` of the measurement's own noise
(``far``: r^T R^-1 r / dof > FAR_SIGMA^2, accepted or not: the solution
departs from the source by many of the source's sigmas) and the lock-out
recoveries (``core.lockout``). The rules, each named in its sentence:

* ``gated``: gated / (accepted + gated) > ``GATED_FAIL`` (0.5, the source is
  mostly refused) fails; > ``GATED_WARN`` (0.05, 500x the 0.9999 gate's
  expected refusals) warns;
* ``nis``: the mean NIS/dof of the accepted updates outside
  [1 / NIS_FAIL, NIS_FAIL] = [0.1, 10] fails, outside [1 / NIS_WARN, NIS_WARN]
  = [0.5, 2] warns (expected: 1; a gate that refuses the large ones biases
  it low, which the ``gated`` rule covers);
* ``departure``: more than ``FAR_FAIL`` (0.2) of the source's updates beyond
  ``FAR_SIGMA`` (5) of its own sigma fails, more than ``FAR_WARN`` (0.02) warns;
* ``lockout``: a lock-out recovery (the filter refused a source that kept
  arriving for ``lockout_timeout_s``: its covariance was optimistic, the
  solution had left the source) warns; ``RECOVERY_FAIL`` (3) or more of one
  source fail: repeated lock-outs mean the configuration does not hold the
  data (measured: the 100x optimistic IMU of ``test_lockout`` needs 3 and 8).

The counts come from the filter itself (``from_filter``, offline) or from the
fusion node's /diagnostics values (``from_values``: ``<kind>_accepted``,
``<kind>_gated``, ``<kind>_mean_nis_per_dof``, ``<kind>_far``,
``<kind>_lockout_recoveries``).
"""
from __future__ import annotations

from dataclasses import dataclass

from hyper_nav_filter.core.lockout import FAR_SIGMA

GATED_FAIL, GATED_WARN = 0.5, 0.05
NIS_FAIL, NIS_WARN = 10.0, 2.0
FAR_FAIL, FAR_WARN = 0.2, 0.02
RECOVERY_FAIL = 3
MIN_UPDATES = 20          # fewer updates of a kind: counts shown, no rule applied


@dataclass(frozen=True)
class SourceStats:
    kind: str
    accepted: int
    gated: int
    mean_nis_per_dof: float        # over the accepted updates (nan: none)
    far: int = 0
    recoveries: int = 0

    @property
    def total(self) -> int:
        return self.accepted + self.gated


def from_filter(kf) -> dict[str, SourceStats]:
    """The counts of an ``ErrorStateKF`` (``stats``, ``watch``)."""
    out = {}
    for kind, (acc, gated, nis_sum) in sorted(kf.stats.items()):
        w = kf.watch.get(kind)
        out[kind] = SourceStats(kind, int(acc), int(gated), nis_sum / acc if acc else float("nan"),
                                int(getattr(w, "far", 0) or 0), int(getattr(w, "recoveries", 0) or 0))
    return out


def from_values(values: dict) -> dict[str, SourceStats]:
    """The counts of the fusion node's /diagnostics key-values."""
    out = {}
    for key in values:
        if not str(key).endswith("_accepted") or str(key).startswith(("imu", "processed", "received")):
            continue
        kind = key[:-len("_accepted")]
        if f"{kind}_gated" not in values:
            continue

        def num(name, default=0.0):
            try:
                return float(values.get(f"{kind}_{name}", default))
            except (TypeError, ValueError):
                return default
        acc = int(num("accepted"))
        out[kind] = SourceStats(kind, acc, int(num("gated")), num("mean_nis_per_dof", float("nan")) if acc
                                else float("nan"), int(num("far")), int(num("lockout_recoveries")))
    return dict(sorted(out.items()))


def check(stats: dict[str, SourceStats], out) -> None:
    """Apply the rules (module docstring) to every source; failures and
    warnings go to ``out`` (a ``run_check.Outcome``), the counts to
    ``out.details['sources']``."""
    out.details["sources"] = {k: {"accepted": s.accepted, "gated": s.gated, "mean_nis_per_dof": s.mean_nis_per_dof,
                                  "far": s.far, "lockout_recoveries": s.recoveries} for k, s in stats.items()}
    for k, s in stats.items():
        if s.total < MIN_UPDATES:
            continue
        frac = s.gated / s.total
        if frac > GATED_FAIL:
            out.failures.append(f"source {k}: rule 'gated': {s.gated} of {s.total} updates refused by the gate "
                                f"({100 * frac:.0f} % > {100 * GATED_FAIL:.0f} %): the filter does not use this "
                                f"source (configured noise or model inconsistent with the data)")
        elif frac > GATED_WARN:
            out.warnings.append(f"source {k}: rule 'gated': {s.gated} of {s.total} updates refused by the gate "
                                f"({100 * frac:.1f} % > {100 * GATED_WARN:.0f} %)")
        m = s.mean_nis_per_dof
        if s.accepted >= MIN_UPDATES and m == m:
            if not 1.0 / NIS_FAIL <= m <= NIS_FAIL:
                out.failures.append(f"source {k}: rule 'nis': mean NIS/dof {m:.3g} of {s.accepted} accepted "
                                    f"updates outside [{1 / NIS_FAIL:g}, {NIS_FAIL:g}] (expected 1)")
            elif not 1.0 / NIS_WARN <= m <= NIS_WARN:
                out.warnings.append(f"source {k}: rule 'nis': mean NIS/dof {m:.3g} of {s.accepted} accepted "
                                    f"updates outside [{1 / NIS_WARN:g}, {NIS_WARN:g}] (expected 1)")
        far = s.far / s.total
        if far > FAR_FAIL:
            out.failures.append(f"source {k}: rule 'departure': {s.far} of {s.total} innovations beyond "
                                f"{FAR_SIGMA:g} sigma of the source's own noise ({100 * far:.0f} % > "
                                f"{100 * FAR_FAIL:.0f} %): the solution departs from the source")
        elif far > FAR_WARN:
            out.warnings.append(f"source {k}: rule 'departure': {s.far} of {s.total} innovations beyond "
                                f"{FAR_SIGMA:g} sigma of the source's own noise ({100 * far:.1f} % > "
                                f"{100 * FAR_WARN:.0f} %)")
        if s.recoveries:
            text = (f"source {k}: rule 'lockout': {s.recoveries} lock-out recover{'y' if s.recoveries == 1 else 'ies'}"
                    f" (refused while consistent for lockout_timeout_s; covariance inflated)")
            if s.recoveries >= RECOVERY_FAIL:
                out.failures.append(text + f", >= {RECOVERY_FAIL}: the configuration does not hold the data "
                                           f"(IMU noise densities, source sigmas)")
            else:
                out.warnings.append(text)


def format_table(stats: dict[str, SourceStats]) -> str:
    """One line per source: accepted, gated, mean NIS/dof, far, recoveries."""
    if not stats:
        return "sources: no aiding update"
    rows = [f"{'source':<14}{'accepted':>10}{'gated':>8}{'gated %':>9}{'NIS/dof':>9}"
            f"{'>' + format(FAR_SIGMA, 'g') + ' sigma':>11}{'recoveries':>12}{'sigma x':>9}"]
    for k, s in stats.items():
        rows.append(f"{k:<14}{s.accepted:>10d}{s.gated:>8d}{100 * s.gated / max(s.total, 1):>9.1f}"
                    f"{s.mean_nis_per_dof:>9.3g}{s.far:>11d}{s.recoveries:>12d}{sigma_scale(s):>9.3g}")
    return ("per source (filter updates; sigma x: sqrt(mean NIS/dof), the factor on the source's sigmas that "
            "would bring its NIS/dof to 1 if the filter's own covariance is right):\n  " + "\n  ".join(rows))


def sigma_scale(s: SourceStats) -> float:
    """sqrt(mean NIS/dof) of the accepted updates (nan without any)."""
    m = s.mean_nis_per_dof
    return float(m) ** 0.5 if m == m and m >= 0 else float("nan")
