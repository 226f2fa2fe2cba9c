"""A message kept as its serialized CDR bytes, its numbers written in place.

The fusion node publishes four messages per IMU sample (issue 35). Through
rclpy each costs a Python message object, its field setters and the C
conversion into the rmw's message before serialization: 75 us of a 120 us
output path per sample on the 2-core bench machine (cProfile of the node,
session 7), more than the engine's predict step. The messages' strings and
sequence lengths (frames, state blocks, covariance size) are fixed for a
run; only numbers change. So each publisher keeps one serialized message
(``rclpy.serialization.serialize_message`` of a prototype: the rmw's own
bytes, never hand-built), the offset of every numeric field in it (CDR
alignment rules, XCDR1 as rmw_fastrtps writes it: each primitive aligned to
its size, up to 8, from the start of the payload after the 4-byte
encapsulation header), writes the numbers there with ``struct`` and
publishes the bytes (``Publisher.publish(bytes)``: rmw_publish_serialized_
message). When a string or a sequence length changes, the template is built
again from the new values (never a wrong message). The layout walk is
checked against ``serialize_message`` for every message type the node
publishes (``test/test_cdr_template.py``).
"""
from __future__ import annotations

import re
import struct

import numpy as np
from rclpy.serialization import serialize_message

from .ros_util import assign_fields

_PRIM = {"double": "d", "float": "f", "int8": "b", "uint8": "B", "octet": "B", "char": "B", "boolean": "?",
         "int16": "h", "uint16": "H", "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q"}
_ARRAY = re.compile(r"^(.+)\[(\d+)\]$")
_SEQ = re.compile(r"^sequence<([^,>]+)(?:, *\d+)?>$")
_STRING = re.compile(r"^string(<\d+>)?$")


class Unsupported(TypeError):
    """A field type this layout walk does not handle (wstring, long double)."""


def _align(off: int, n: int) -> int:
    """Offset ``off`` of the whole buffer aligned to ``n`` bytes of the payload (after the 4-byte header)."""
    rel = off - 4
    return off + (-rel) % min(n, 8)


def _walk(msg, buf: bytes, off: int, prefix: str, numbers: dict, fixed: dict) -> int:
    """Offsets of ``msg``'s numeric fields (``numbers``: path -> (offset,
    struct code, count)) and its strings and lengths (``fixed``: path ->
    value); returns the offset after the message."""
    for name, typ in msg.get_fields_and_field_types().items():
        path, value = prefix + name, getattr(msg, name)
        m_arr, m_seq = _ARRAY.match(typ), _SEQ.match(typ)
        if typ in _PRIM:
            code = _PRIM[typ]
            off = _align(off, struct.calcsize(code))
            numbers[path] = (off, code, None)
            off += struct.calcsize(code)
        elif _STRING.match(typ):
            off = _string(buf, off, path, value, fixed)
        elif m_arr or m_seq:
            elem = (m_arr or m_seq).group(1)
            n = len(value)
            if m_seq:
                off = _align(off, 4)
                fixed[path + "#len"] = n
                off += 4
            if elem in _PRIM:
                code = _PRIM[elem]
                size = struct.calcsize(code)
                if n:
                    off = _align(off, size)
                numbers[path] = (off, code, n)
                off += size * n
            elif _STRING.match(elem):
                fixed[path] = list(value)
                for i, s in enumerate(value):
                    off = _string(buf, off, f"{path}.{i}", s, {})
            elif "/" in elem:
                for i, sub in enumerate(value):
                    off = _walk(sub, buf, off, f"{path}.{i}.", numbers, fixed)
            else:
                raise Unsupported(f"{path}: {typ}")
        elif "/" in typ:
            off = _walk(value, buf, off, path + ".", numbers, fixed)
        else:
            raise Unsupported(f"{path}: {typ}")
    return off


def _string(buf: bytes, off: int, path: str, value: str, fixed: dict) -> int:
    off = _align(off, 4)
    n = struct.unpack_from("<I", buf, off)[0]
    fixed[path] = value
    return off + 4 + n


class CdrTemplate:
    """One publisher's message as CDR bytes.

    ``fill(fields)`` takes the flat ``{'a.b': value}`` dicts of ``output.py``
    (the same that ``ros_util.assign_fields`` takes); ``prototype(fields)``
    builds the message from them when the template must be (re)built
    (default: the message class filled by ``assign_fields``); ``prefix``
    maps the dict's paths into the message (``transforms.0.`` for one
    TransformStamped in a TFMessage)."""

    def __init__(self, msg_class, prototype=None, prefix: str = ""):
        self.msg_class = msg_class
        self._prototype = prototype or (lambda f: _assigned(msg_class(), f))
        self._prefix = prefix
        self._buf = None
        self.n_builds = 0

    def _build(self, fields: dict) -> None:
        msg = self._prototype(fields)
        raw = serialize_message(msg)
        if raw[:2] != b"\x00\x01":             # CDR, little-endian: what the walk assumes
            raise Unsupported(f"{self.msg_class.__name__}: encapsulation {raw[:4].hex()}")
        numbers, fixed = {}, {}
        end = _walk(msg, raw, 4, "", numbers, fixed)
        if end > len(raw) or len(raw) - end > 3:
            raise Unsupported(f"{self.msg_class.__name__}: layout ends at {end} of {len(raw)} bytes")
        k = len(self._prefix)
        self._numbers = {p[k:]: (o, struct.Struct("<" + c), n, np.dtype("<" + c) if c != "?" else np.dtype("?"))
                         for p, (o, c, n) in numbers.items() if p.startswith(self._prefix)}
        self._fixed = {p[k:]: v for p, v in fixed.items() if p.startswith(self._prefix)}
        self._buf = bytearray(raw)
        self._view = memoryview(self._buf)
        self.n_builds += 1

    def fill(self, fields: dict) -> None:
        """Write ``fields`` into the bytes (``bytes()`` then gives the message)."""
        if self._buf is None:
            self._build(fields)
            return
        numbers, buf, view, fixed = self._numbers, self._buf, self._view, self._fixed
        for path, value in fields.items():
            spec = numbers.get(path)
            if spec is None:
                if fixed.get(path, _MISSING) != (list(value) if isinstance(value, (list, tuple)) else value):
                    self._build(fields)
                    return
                continue
            off, st, n, dt = spec
            if n is None:
                st.pack_into(buf, off, value)
                continue
            arr = np.asarray(value, dtype=dt).ravel()
            if arr.size != n:
                if (path + "#len") not in fixed:
                    raise ValueError(f"{path}: {n} values expected, {arr.size} given")
                self._build(fields)
                return
            view[off:off + arr.nbytes] = arr.tobytes()

    def set_stamp(self, path: str, sec: int, nanosec: int) -> None:
        """Overwrite a ``builtin_interfaces/Time`` (``path`` + ``.sec`` / ``.nanosec``) in the bytes."""
        o, st, _, _ = self._numbers[path + ".sec"]
        st.pack_into(self._buf, o, sec)
        o, st, _, _ = self._numbers[path + ".nanosec"]
        st.pack_into(self._buf, o, nanosec)

    def bytes(self) -> bytes:
        return bytes(self._buf)


_MISSING = object()


def _assigned(msg, fields):
    assign_fields(msg, fields)
    return msg
