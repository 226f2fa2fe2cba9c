"""Time of a sample counter: RTKLIB time-tag files and counter -> time tables.

An IMU logged beside a receiver often stamps its samples with the logger's
millisecond tick (``tickget()``), not with GNSS time. RTKLIB (str2str,
rtkrcv, RTKNAVI with "time-tag" on) writes, next to each logged stream, a
binary ``<file>.tag`` (RTKLIB 2.4.3 / demo5 ``stream.c``, ``openfile_`` and
``writefile``), little-endian:

  header  64 bytes   text "TIMETAG RTKLIB <version>", NUL padded; byte 59:
                     size of the file positions below (4 or 8; 0 in older
                     files = 4); bytes 60-63: tick_f, the tick (ms, uint32)
                     when the file was opened
  time    uint32 + float64   GPST of the file start as RTKLIB's gtime_t:
                     seconds since 1970-01-01 on the GPS time scale, + fraction
  records (tick uint32 ms, file position uint32 | uint64) per write

So a tick c (ms) of the same clock is at GPST t0 + (c - tick_f) / 1000 s; the
records give the ticks the receiver stream was written at (read and
counted, not needed for the mapping). Times leave here as continuous GPST
seconds since 1980-01-06 (RTKLIB's ``.pos`` time axis, ``rtklib_pos``).

Any other counter: a ``map`` table of (counter, time) pairs, linearly
interpolated (a counter outside the table is an error naming the row).
"""
from __future__ import annotations

import math
import pathlib
import struct
from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core.params import ConfigError

HEADER_LEN = 64
GPST_UNIX_OFFSET_S = 315964800.0     # 1980-01-06 - 1970-01-01 (s)


@dataclass(frozen=True)
class TimeTag:
    version: str                     # header text
    t_start_gpst_s: float            # continuous GPST seconds since 1980-01-06 of the file start
    tick_f_ms: int                   # tick at the file start
    ticks_ms: np.ndarray             # tick of each record
    fpos: np.ndarray                 # file position of each record

    def gpst_of_ticks(self, ticks_ms) -> np.ndarray:
        """GPST (s since 1980-01-06) of ticks of the logger's ms clock (uint32 wrap handled
        relative to tick_f)."""
        d = (np.asarray(ticks_ms, float) - self.tick_f_ms) % 2.0 ** 32
        d = np.where(d > 2.0 ** 31, d - 2.0 ** 32, d)        # a tick before the file start
        return self.t_start_gpst_s + d * 1e-3


def read_tag(path, where: str = "imu.time.tag") -> TimeTag:
    """Read an RTKLIB time-tag file (module docstring); ConfigError naming
    ``where`` when it is not one."""
    path = pathlib.Path(path)
    if not path.exists():
        raise ConfigError(f"{where}: {path} not found")
    raw = path.read_bytes()
    if len(raw) < HEADER_LEN + 12 or not raw.startswith(b"TIMETAG"):
        raise ConfigError(f"{where}: {path} is not an RTKLIB time-tag file (no 'TIMETAG' header of "
                          f"{HEADER_LEN} + 12 bytes; {len(raw)} bytes)")
    head = raw[:HEADER_LEN]
    version = head[:HEADER_LEN - 5].split(b"\0", 1)[0].decode("ascii", "replace").strip()
    size_fpos = head[HEADER_LEN - 5] or 4
    if size_fpos not in (4, 8):
        raise ConfigError(f"{where}: {path}: file-position size {size_fpos} (byte 59 of the header; 4 or 8 expected)")
    tick_f = struct.unpack_from("<I", head, HEADER_LEN - 4)[0]
    time_time, time_sec = struct.unpack_from("<Id", raw, HEADER_LEN)
    body = raw[HEADER_LEN + 12:]
    rec = np.dtype([("tick", "<u4"), ("fpos", "<u4" if size_fpos == 4 else "<u8")])
    n = len(body) // rec.itemsize
    recs = np.frombuffer(body[:n * rec.itemsize], dtype=rec)
    t0 = float(time_time) - GPST_UNIX_OFFSET_S + float(time_sec)
    if not math.isfinite(t0) or t0 < 0:
        raise ConfigError(f"{where}: {path}: start time {time_time} + {time_sec} s is not a GPST epoch")
    return TimeTag(version, t0, int(tick_f), recs["tick"].astype(np.int64), recs["fpos"].astype(np.int64))


def write_tag(path, t_start_gpst_s: float, tick_f_ms: int, records=(), version: str = "TIMETAG RTKLIB demo5",
              size_fpos: int = 4) -> None:
    """Write a time-tag file in the same layout (tests, tools)."""
    head = bytearray(HEADER_LEN)
    text = version.encode("ascii")[:HEADER_LEN - 5]
    head[:len(text)] = text
    head[HEADER_LEN - 5] = size_fpos
    struct.pack_into("<I", head, HEADER_LEN - 4, int(tick_f_ms))
    t_unix = t_start_gpst_s + GPST_UNIX_OFFSET_S
    whole = math.floor(t_unix)
    out = bytes(head) + struct.pack("<Id", int(whole), t_unix - whole)
    fmt = "<II" if size_fpos == 4 else "<IQ"
    out += b"".join(struct.pack(fmt, int(t), int(p)) for t, p in records)
    pathlib.Path(path).write_bytes(out)


def map_counter(counter, table: np.ndarray, where: str) -> np.ndarray:
    """Times of ``counter`` values from a (counter, time) table, linear
    between its rows; ConfigError outside the table."""
    c = np.asarray(counter, float)
    tab = np.asarray(table, float)
    if tab.ndim != 2 or tab.shape[1] != 2 or len(tab) < 2:
        raise ConfigError(f"{where}: expected at least 2 (counter, time) rows")
    if np.any(np.diff(tab[:, 0]) <= 0):
        k = int(np.argmax(np.diff(tab[:, 0]) <= 0))
        raise ConfigError(f"{where}: counter not increasing at row {k + 2} ({tab[k, 0]!r} -> {tab[k + 1, 0]!r})")
    out = (c < tab[0, 0]) | (c > tab[-1, 0])
    if np.any(out):
        k = int(np.argmax(out))
        raise ConfigError(f"{where}: counter {c[k]!r} of data row {k + 1} outside the table "
                          f"[{tab[0, 0]!r}, {tab[-1, 0]!r}]")
    return np.interp(c, tab[:, 0], tab[:, 1])
