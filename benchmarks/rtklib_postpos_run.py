"""RTKLIB's own ``postpos`` (the engine of ``rnx2rtkp``, through pyrtklib) as
a whole process, for timing beside the whole ``spp`` command: reads plain
RINEX files (RTKLIB's own reader), solves single point with the options of
``hyper_nav_workbench.core.rtklib_reference._options`` (the systems, the mask,
IFLC or broadcast ionosphere, Saastamoinen troposphere) and writes an llh
``.pos``. Imports pyrtklib only, as ``rnx2rtkp`` would load nothing else.

Run: python benchmarks/rtklib_postpos_run.py OUT.pos OBS NAV... [--mode dual|single] [--systems GEC] [--mask 10]

The files must be plain RINEX (RTKLIB's decompression calls programs that
are not installed here): ``spp_vs_rtklib.py`` decompresses them once into a
temporary folder and hands both commands the same plain files.
"""
from __future__ import annotations

import argparse
import math
import sys


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out")
    ap.add_argument("files", nargs="+", help="OBS NAV... (plain RINEX)")
    ap.add_argument("--mode", choices=("dual", "single"), default="dual")
    ap.add_argument("--systems", default="GEC")
    ap.add_argument("--mask", type=float, default=10.0)
    a = ap.parse_args(argv)
    import pyrtklib as rk
    opt = rk.prcopt_default
    opt.mode = rk.PMODE_SINGLE
    mask = 0
    for s in a.systems.upper():
        mask |= {"G": rk.SYS_GPS, "E": rk.SYS_GAL, "C": rk.SYS_CMP, "J": rk.SYS_QZS}[s]
    opt.navsys = mask
    dual = a.mode == "dual"
    opt.ionoopt = rk.IONOOPT_IFLC if dual else rk.IONOOPT_BRDC
    opt.tropopt = rk.TROPOPT_SAAS
    opt.elmin = math.radians(a.mask)
    opt.nf = 2 if dual else 1
    sopt = rk.solopt_default
    sopt.posf, sopt.times, sopt.timef, sopt.timeu = rk.SOLF_LLH, rk.TIMES_GPST, 1, 3
    sopt.outhead, sopt.height, sopt.sstat, sopt.trace, sopt.outvel = 1, 0, 0, 0, 0
    fopt = rk.filopt_t()
    t0 = rk.gtime_t()
    ret = rk.postpos(t0, t0, 0.0, 0.0, opt, sopt, fopt, list(a.files), len(a.files), rk.Arr1Dchar(a.out), "", "")
    if ret != 0:
        print(f"postpos returned {ret}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
