"""Array forms for long replays: NavState states from a topic read as field
arrays (``bag_arrays.TopicArrays``), and text tables written by one format
operation. The errors themselves are ``core.scoring``'s (one implementation).

Measured (CPU seconds, least of three, 2-core machine at load 17, the
300 s peer-format set): a 15,001 x 22 STD table through ``np.savetxt``
0.17 s, as one format operation 0.13 s (the same text); the truth's
rotations of 60,001 rows from quaternions one row at a time 4.39 s, as one
stack 0.17 s.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation


def states_from_topic(truth) -> dict:
    """``scoring.states_from_msgs`` of NavState messages read as arrays (``bag_arrays.TopicArrays``)."""
    q = np.column_stack([truth[f"q_b_enu.{a}"] for a in "xyzw"])
    return {"t": truth.stamp_s, "lat": truth["lat_rad"].astype(float), "lon": truth["lon_rad"].astype(float),
            "alt": truth["alt_m"].astype(float), "vel": truth["vel_enu_mps"].astype(float).reshape(-1, 3),
            "C": Rotation.from_quat(q).as_matrix() if len(q) else np.zeros((0, 3, 3))}


# libm's atan2 and hypot element by element (numpy's own loops run them in C over the array): numpy's SIMD
# arctan2 and hypot differ from libm in the last bit (AVX-512 machine, numpy 2.2: arctan2 on 7 % of random
# arguments, hypot on 0.6 %), which moves 9th decimals of the .nav text
_atan2 = np.frompyfunc(math.atan2, 2, 1)
_hypot = np.frompyfunc(math.hypot, 2, 1)


def euler_rows(C_b_n) -> np.ndarray:
    """(n, 3) roll, pitch, heading (rad, heading in [0, 2 pi)) of a stack of
    C_b_n (n, 3, 3): ``attitude.C_b_n_to_euler``'s closed form for one matrix,
    applied column-wise with the same float operations in the same order, so
    the same numbers bit for bit (scipy's stack, the function's own branch
    for a stack, agrees to 1e-12 rad only). Peer-format set, 168,101
    matrices: one call per matrix 0.19 s, this 0.05 s (CPU, same process)."""
    C = np.asarray(C_b_n, float).reshape(-1, 3, 3)

    def f(fn, a, b):
        return fn(a, b).astype(float) if len(a) else np.zeros(0)
    c_y = f(_hypot, C[:, 2, 1], C[:, 2, 2])
    y = f(_atan2, -C[:, 2, 0], c_y)
    ok = c_y > 1e-12
    z = np.empty(len(C))
    x = np.zeros(len(C))                       # gimbal lock: roll folded into heading, as scipy does
    z[ok] = f(_atan2, C[ok, 1, 0], C[ok, 0, 0])
    x[ok] = f(_atan2, C[ok, 2, 1], C[ok, 2, 2])
    z[~ok] = f(_atan2, -C[~ok, 0, 1], C[~ok, 1, 1])
    return np.column_stack([x, -y, (math.pi / 2 - z) % (2 * math.pi)])


def format_rows(rows: np.ndarray, precision: int = 9) -> str:
    """The text ``np.savetxt(path, rows, fmt=f"%.{precision}f", delimiter=" ")``
    writes, made by one format operation over the whole table."""
    rows = np.asarray(rows, float)
    if rows.ndim != 2 or not rows.size:
        return ""
    line = " ".join([f"%.{precision}f"] * rows.shape[1]) + "\n"
    return (line * rows.shape[0]) % tuple(rows.ravel().tolist())


# ---- the same text, compiled (issue 41) ------------------------------------------------
# '%.{p}f' % x is x's exact binary value rounded to p decimals. y = |x| 10^p in float64 is that value to half
# an ulp (10^p exact for p <= 22: one rounding), so floor(y + 1/2) is its rounding unless y's fraction is
# within 2^-50 y (at least 4 ulps) of 1/2; those, NaN, inf and |x| >= 2^22 are formatted by Python. The test
# is the same exact float operations in the kernel and in ``_needs_python`` (which picks them beforehand).
_FAST_ABS_MAX = 4194304.0          # 2^22: y < 2^52, where y + 1/2 is exact
_TIE_MARGIN = 2.0 ** -50


def _format_kernel_py(x, p, scale, fallback, fb_offs, out):
    """The text of the rows of x (n, m), ``p`` decimals (``scale`` = 10.0**p),
    values separated by ' ', rows ended by '\\n', into ``out``; ``fallback``
    holds, concatenated, the Python text of each value ``_needs_python``
    flags (``fb_offs`` its bounds, row-major order). Returns the bytes
    written (out holds p + 10 per value plus the fallback text)."""
    n = x.shape[0]
    m = x.shape[1]
    pos = 0
    k = 0
    tens = 1
    for _ in range(p):
        tens *= 10
    digits = np.empty(24, np.uint8)
    for i in range(n):
        for j in range(m):
            v = x[i, j]
            a = abs(v)
            fast = a < 4194304.0                     # _FAST_ABS_MAX (NaN compares False)
            y = 0.0
            if fast:
                y = a * scale
                if abs((y - math.floor(y)) - 0.5) <= y * 8.881784197001252e-16:     # _TIE_MARGIN
                    fast = False
            if fast:
                N = np.int64(math.floor(y + 0.5))
                if math.copysign(1.0, v) < 0.0:
                    out[pos] = 45                    # '-'
                    pos += 1
                ip = N // tens
                fp = N - ip * tens
                nd = 0
                if ip == 0:
                    digits[0] = 48
                    nd = 1
                while ip > 0:
                    digits[nd] = 48 + ip % 10
                    ip //= 10
                    nd += 1
                for d in range(nd - 1, -1, -1):
                    out[pos] = digits[d]
                    pos += 1
                if p > 0:
                    out[pos] = 46                    # '.'
                    pos += 1
                    for d in range(p - 1, -1, -1):
                        out[pos + d] = 48 + fp % 10
                        fp //= 10
                    pos += p
            else:
                a0, a1 = fb_offs[k], fb_offs[k + 1]
                for q in range(a0, a1):
                    out[pos] = fallback[q]
                    pos += 1
                k += 1
            out[pos] = 10 if j == m - 1 else 32      # '\n' at the row's end, else ' '
            pos += 1
    return pos


try:
    from numba import njit as _njit
    _format_kernel = _njit(cache=True, nogil=True)(_format_kernel_py)
except Exception:  # pragma: no cover - numba missing: format_rows' one format operation
    _format_kernel = None


def _needs_python(x: np.ndarray, scale: float) -> np.ndarray:
    """The values the kernel leaves to Python's formatting (its test, over the array)."""
    a = np.abs(x)
    with np.errstate(invalid="ignore"):
        fast = a < _FAST_ABS_MAX
        y = np.where(fast, a, 0.0) * scale
        fast &= ~(np.abs((y - np.floor(y)) - 0.5) <= y * _TIE_MARGIN)
    return ~fast


def format_rows_compiled(rows: np.ndarray, precision: int = 9) -> bytes:
    """``format_rows``' text, byte for byte, written by a compiled loop (the
    digits of the exactly rounded value, see above) with Python's own
    formatting for the values it cannot round surely. Peer-format set, .nav
    and STD (168,101 x 11 and x 22): 0.31 and 0.60 s -> 0.065 and 0.14 s
    CPU (same process, the same bytes)."""
    rows = np.ascontiguousarray(rows, float)
    if rows.ndim != 2 or not rows.size or _format_kernel is None or not 0 <= precision <= 15:
        return format_rows(rows, precision).encode()
    scale = float(10 ** precision)
    flag = _needs_python(rows, scale)
    fmt = f"%.{precision}f"
    texts = [(fmt % v).encode() for v in rows[flag].tolist()]
    fb = np.frombuffer(b"".join(texts), np.uint8) if texts else np.zeros(0, np.uint8)
    offs = np.zeros(len(texts) + 1, np.int64)
    if texts:
        offs[1:] = np.cumsum([len(t) for t in texts])
    out = np.empty(rows.size * (precision + 10) + len(fb), np.uint8)
    n = _format_kernel(rows, precision, scale, fb, offs, out)
    return out[:n].tobytes()


def write_rows(path, rows: np.ndarray, precision: int = 9) -> None:
    """``format_rows``' text into ``path`` (the compiled writer, the same bytes)."""
    with open(path, "wb") as f:
        f.write(format_rows_compiled(rows, precision))
