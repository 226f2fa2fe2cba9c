"""Write an SP3-c/d file (IGS SP3-d format description, 2016) from rows
(t_gpst_s, sat, r_e_m (3,), clk_s or NaN): for the tests, which hold the
shared SP3 extracts only as CSV text."""
from __future__ import annotations

import datetime as _dt

import numpy as np

_GPS0 = _dt.datetime(1980, 1, 6)


def _cal(t_gpst_s: float) -> _dt.datetime:
    return _GPS0 + _dt.timedelta(seconds=float(t_gpst_s))


def write_sp3(path, rows, version: str = "d", frame: str = "IGS20", agency: str = "TEST", drop=(),
              time_system: str = "GPS") -> None:
    """``drop``: (t_gpst_s, sat) records left out (a satellite missing at an epoch)."""
    drop = {(round(t, 3), s) for t, s in drop}
    times = sorted({r[0] for r in rows})
    sats = sorted({r[1] for r in rows})
    by = {(r[0], r[1]): r for r in rows}
    t0 = _cal(times[0])
    interval = times[1] - times[0]
    week, sow = divmod(times[0], 604800.0)
    mjd = (t0 - _dt.datetime(1858, 11, 17)).days
    frac = (t0.hour * 3600 + t0.minute * 60 + t0.second) / 86400.0
    out = [f"#{version}P{t0.year:4d} {t0.month:2d} {t0.day:2d} {t0.hour:2d} {t0.minute:2d} {t0.second:11.8f} "
           f"{len(times):7d} ORBIT {frame:5s} FIT {agency:4s}",
           f"## {int(week):4d} {sow:15.8f} {interval:14.8f} {mjd:5d} {frac:15.13f}"]
    padded = sats + ["  0"] * (max(85, -(-len(sats) // 17) * 17) - len(sats))
    for k in range(0, len(padded), 17):
        head = (f"+   {len(sats):2d}   " if version == "c" else f"+  {len(sats):3d}   ") if k == 0 else "+        "
        out.append(head + "".join(padded[k:k + 17]))
    for k in range(0, len(padded), 17):
        out.append("++       " + "  0" * 17)
    out += [f"%c G  cc {time_system:3s} ccc cccc cccc cccc cccc ccccc ccccc ccccc ccccc",
            "%c cc cc ccc ccc cccc cccc cccc cccc ccccc ccccc ccccc ccccc",
            "%f  1.2500000  1.025000000  0.00000000000  0.000000000000000",
            "%f  0.0000000  0.000000000  0.00000000000  0.000000000000000",
            "%i    0    0    0    0      0      0      0      0         0",
            "%i    0    0    0    0      0      0      0      0         0",
            "/* written by hyper-nav's tests from a CSV extract"]
    for t in times:
        c = _cal(t)
        out.append(f"*  {c.year:4d} {c.month:2d} {c.day:2d} {c.hour:2d} {c.minute:2d} {c.second:11.8f}")
        for s in sats:
            r = by.get((t, s))
            if r is None or (round(t, 3), s) in drop:
                continue
            x, y, z = np.asarray(r[2], float) / 1e3
            clk = 999999.999999 if not np.isfinite(r[3]) else r[3] * 1e6
            out.append(f"P{s}{x:14.6f}{y:14.6f}{z:14.6f}{clk:14.6f}")
    out.append("EOF")
    with open(path, "w") as fh:
        fh.write("\n".join(out) + "\n")


def write_clk(path, rows, version: float = 3.00, time_system: str = "GPS") -> None:
    """A RINEX CLK file of satellite clock (AS) records from rows (t_gpst_s, sat, clk_s); NaN clocks left out."""
    out = [f"{version:9.2f}           C                   G                   RINEX VERSION / TYPE",
           f"   {time_system:3s}{'':54s}TIME SYSTEM ID",
           f"{'':60s}END OF HEADER"]
    for t, sat, clk in sorted(rows, key=lambda r: (r[0], r[1])):
        if not np.isfinite(clk):
            continue
        c = _cal(t)
        out.append(f"AS {sat:3s}  {c.year:4d} {c.month:02d} {c.day:02d} {c.hour:02d} {c.minute:02d} "
                   f"{c.second + c.microsecond * 1e-6:9.6f}  1   {clk:19.12E}")
    with open(path, "w") as fh:
        fh.write("\n".join(out) + "\n")


def write_antex(path, sats: dict, receiver: bool = True, version: float = 1.4) -> None:
    """An ANTEX file of satellite entries ``{sat: [(valid_from_gpst_s or None, valid_until or None,
    {freq: (x, y, z) m})]}`` (plus one receiver antenna entry that the reader must skip)."""
    def lab(text, label):
        return f"{text:60s}{label}"

    def date(t):
        c = _cal(t)
        return f"  {c.year:4d}    {c.month:2d}    {c.day:2d}    {c.hour:2d}    {c.minute:2d}   {c.second:10.7f}"
    out = [lab(f"{version:8.1f}            M", "ANTEX VERSION / SYST"), lab("A", "PCV TYPE / REFANT"),
           lab("", "END OF HEADER")]
    blocks = []
    if receiver:
        blocks.append(("TRM59800.00     NONE", "", None, None, {"G01": (0.0011, 0.0005, 0.0660)}))
    for sat, entries in sats.items():
        for a, b, pcos in entries:
            blocks.append((f"BLOCK TEST {sat[0]}", sat, a, b, pcos))
    for typ, serial, a, b, pcos in blocks:
        out += [lab("", "START OF ANTENNA"), lab(f"{typ:20s}{serial:20s}", "TYPE / SERIAL NO"),
                lab("     0.0", "DAZI"), lab("     0.0  17.0   1.0", "ZEN1 / ZEN2 / DZEN"),
                lab(f"{len(pcos):6d}", "# OF FREQUENCIES")]
        if a is not None:
            out.append(lab(date(a), "VALID FROM"))
        if b is not None:
            out.append(lab(date(b), "VALID UNTIL"))
        for f, (x, y, z) in pcos.items():
            out += [lab(f"   {f}", "START OF FREQUENCY"),
                    lab(f"{x * 1e3:10.2f}{y * 1e3:10.2f}{z * 1e3:10.2f}", "NORTH / EAST / UP"),
                    "   NOAZI    0.00    0.00    0.00",
                    lab(f"   {f}", "END OF FREQUENCY")]
        out.append(lab("", "END OF ANTENNA"))
    with open(path, "w") as fh:
        fh.write("\n".join(out) + "\n")
