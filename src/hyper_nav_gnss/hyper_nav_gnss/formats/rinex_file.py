"""RINEX files as archives hold them: the text of a file compressed with
gzip (``.gz``), Unix compress (``.Z``, LZW), zip (``.zip``, one member),
bzip2, and/or Hatanaka (Compact RINEX ``.crx`` / ``.yyd``; Hatanaka 1996),
recognised by their content, not their name (the ``hatanaka`` package does
the decompression), and the ``RINEX VERSION / TYPE`` line checked.

:func:`read_rinex_text` returns the plain text; :func:`rinex_version` the
version, file type and satellite system of the first line, or a
:class:`RinexFormatError` that names the file, the line and what it found.
"""
from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path


class RinexFormatError(ValueError):
    """A file that is not what the reader can read: names the file, the line and what."""

    def __init__(self, path, line: int | None, what: str):
        self.path, self.line, self.what = str(path), line, what
        where = f"{Path(path).name}" + (f" line {line}" if line else "")
        super().__init__(f"{where}: {what}")


@dataclass(frozen=True)
class RinexVersion:
    version: float          # e.g. 2.11, 3.05, 4.01
    file_type: str          # O observation, N navigation (G: RINEX 2 GLONASS nav, ...)
    system: str             # G, R, E, C, J, S, M (mixed); ' ' = GPS in RINEX 2

    @property
    def major(self) -> int:
        return int(self.version)


def read_rinex_bytes(path) -> bytes:
    """The decompressed bytes of ``path`` (any of the module docstring's
    compressions, or none). Raises RinexFormatError for an empty file, an
    empty or multi-member zip, or a decompression failure."""
    p = Path(path)
    data = p.read_bytes()
    if not data:
        raise RinexFormatError(p, None, "empty file")
    if data[:2] == b"PK":                        # zip: one member (the RINEX file)
        import io
        try:
            with zipfile.ZipFile(io.BytesIO(data)) as z:
                names = [n for n in z.namelist() if not n.endswith("/")]
                if len(names) != 1:
                    raise RinexFormatError(p, None, f"zip archive with {len(names)} files ({names[:5]}); "
                                                    "expected one RINEX file")
                data = z.read(names[0])
        except zipfile.BadZipFile as exc:
            raise RinexFormatError(p, None, f"damaged zip archive ({exc})") from None
    head = data[:200]
    if head[:2] not in (b"\x1f\x8b", b"\x1f\x9d") and head[:3] != b"BZh" and b"COMPACT RINEX" not in head:
        return data                              # plain text: checked by rinex_version
    import hatanaka
    try:
        out = hatanaka.decompress(data)
    except Exception as exc:                    # hatanaka raises its own and ValueError/OSError
        raise RinexFormatError(p, None, f"could not decompress ({type(exc).__name__}: {exc})") from None
    if not out:
        raise RinexFormatError(p, None, "empty after decompression")
    return out


def read_rinex_text(path) -> str:
    """The plain RINEX text of ``path`` (module docstring)."""
    return read_rinex_bytes(path).decode("ascii", errors="replace")


def rinex_version(lines, path) -> RinexVersion:
    """The first line's ``RINEX VERSION / TYPE`` (RINEX 2.11 / 3.05 / 4.01
    section 5: F9.2, 11X, A1 type, 19X, A1 system)."""
    first = lines[0] if lines else ""
    if first[60:].strip() != "RINEX VERSION / TYPE":
        raise RinexFormatError(path, 1, f"not a RINEX file: first line {first[:60].rstrip()!r} has no "
                                        "'RINEX VERSION / TYPE' label in columns 61-80")
    try:
        v = float(first[:9])
    except ValueError:
        raise RinexFormatError(path, 1, f"RINEX version {first[:9]!r} is not a number") from None
    return RinexVersion(v, first[20:21].upper(), (first[40:41] or " ").upper())
