"""Seed 001 reproduction: the HWIL figures (largest per-axis errors) over a
Monte Carlo campaign of the ``seed001`` scenario on its LCI filter.

    ros2run hyper_nav_repro repro_seed001 [--runs 10] [--out results/seed001]   # = make repro-seed001

The campaign is ``mc_campaign`` (``hyper_nav_sim``) with the seed's defaults
(scenario ``seed001``, 10 runs); every ``mc_campaign`` option passes through
and overrides them. ``campaign.json`` carries the per-run largest |error|
on any axis beside the paper's per-axis bounds (the scenario's
``report.reference_*``).
"""
from __future__ import annotations

import sys

from hyper_nav_workbench import mc_campaign

DEFAULTS = ["--scenario", "seed001", "--runs", "10", "--out", "results/seed001"]


def main(argv=None) -> int:
    return mc_campaign.main(DEFAULTS + list(sys.argv[1:] if argv is None else argv))


if __name__ == "__main__":
    sys.exit(main())
