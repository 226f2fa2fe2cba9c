"""rosbag2 bags with MCAP storage: write and read raw CDR messages without ROS.

Layout of a bag (as written by ``ros2 bag record -s mcap`` and by rosbags)::

    <bag>/                  the bag is a directory
        metadata.yaml       rosbag2 summary: topics, types, counts, start/duration
        <bag>_0.mcap        the messages (rosbags names it <bag>.mcap)

Every message is stored as its CDR bytes with a log time: integer nanoseconds
on the recorder's clock (ROS time; sim time when the recorder runs with
``use_sim_time``), not the ``header.stamp`` inside the message. Message types
are ROS 2 names such as ``sensor_msgs/msg/Imu`` or ``hyper_nav_msgs/msg/NavState``;
the MCAP file carries the schema (.msg text) of every type it holds.

Pure Python (rosbags), no rclpy: usable offline and in tests. A bag cut short
(recorder killed, disk full) is read with a tolerant MCAP parser that returns
every complete message before the cut and reports the damage; see
:class:`BagReader`.
"""

from __future__ import annotations

import errno
import functools
import struct
from pathlib import Path
from typing import Iterable, Iterator, NamedTuple

from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2.errors import WriterError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

MSG_PACKAGE = "hyper_nav_msgs"


class Record(NamedTuple):
    """One stored message: topic, type name, log time (ns), CDR bytes."""

    topic: str
    msgtype: str
    t_ns: int
    raw: bytes


def _msg_dir() -> Path:
    """Directory of the project's .msg files: installed share dir, else the source tree."""
    try:
        from ament_index_python.packages import get_package_share_directory

        installed = Path(get_package_share_directory(MSG_PACKAGE)) / "msg"
        if installed.is_dir():
            return installed
    except Exception:  # PackageNotFoundError, or ament_index_python missing
        pass
    return Path(__file__).resolve().parents[3] / MSG_PACKAGE / "msg"


@functools.lru_cache(maxsize=1)
def typestore():
    """ROS 2 Jazzy typestore with the ``hyper_nav_msgs`` types registered (cached)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types = {}
    for msg in sorted(_msg_dir().glob("*.msg")):
        types.update(get_types_from_msg(msg.read_text(), f"{MSG_PACKAGE}/msg/{msg.stem}"))
    store.register(types)
    return store


def serialize(msg, msgtype: str) -> bytes:
    """Serialize a rosbags message object to little-endian CDR bytes."""
    return bytes(typestore().serialize_cdr(msg, msgtype))


def deserialize(raw: bytes, msgtype: str):
    """Deserialize CDR bytes to a rosbags message object (dataclass, arrays as numpy)."""
    return typestore().deserialize_cdr(raw, msgtype)


class BagWriter:
    """Write already serialized (CDR) messages into a new rosbag2/MCAP bag.

    ``compression``: None (uncompressed chunks) or ``"zstd"`` (zstd-compressed
    MCAP chunks; metadata.yaml and the file name stay as without compression).
    Refuses an existing path (FileExistsError). Use as a context manager, or
    call :meth:`close` to write the MCAP summary and metadata.yaml.
    """

    def __init__(self, path, compression: str | None = None):
        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(errno.EEXIST, "bag exists already, not overwriting", str(self.path))
        self._writer = Writer(self.path, version=Writer.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP)
        if compression == "zstd":
            self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        elif compression is not None:
            raise ValueError(f"unsupported compression {compression!r} (None or 'zstd')")
        try:
            self._writer.open()
        except WriterError as exc:  # created by someone else since the check above
            raise FileExistsError(errno.EEXIST, str(exc), str(self.path)) from None
        self._connections = {}
        self.counts: dict[str, int] = {}

    def write(self, topic: str, msgtype: str, t_ns: int, raw: bytes) -> None:
        """Append one message: CDR bytes ``raw`` of type ``msgtype`` logged at ``t_ns`` (ns)."""
        key = (topic, msgtype)
        if key not in self._connections:
            self._connections[key] = self._writer.add_connection(topic, msgtype, typestore=typestore())
        self._writer.write(self._connections[key], int(t_ns), raw)
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def flush(self) -> None:
        """Push buffered messages to disk so a crash loses only what came after.

        rosbags keeps up to 1 MiB of messages in an in-memory chunk; this ends
        that chunk early. Relies on rosbags' McapWriter (checked at runtime).
        """
        storage = self._writer.storage
        chunk = getattr(storage, "chunk", None)
        if chunk is not None and chunk.msgs and hasattr(storage, "close_chunk"):
            storage.close_chunk()
            storage.bio.flush()

    def close(self) -> None:
        """Finish the MCAP file (summary, footer) and write metadata.yaml. Idempotent."""
        if self._writer.storage is not None:
            self._writer.close()

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class BagReader:
    """Iterate over a bag's messages as :class:`Record` in log-time order.

    ``topics``: iterable of topic names to keep (None = all). ``.topics`` maps
    topic -> msgtype and is known after construction. After a full iteration:
    ``.counts`` (topic -> records yielded), ``.truncated`` (the MCAP data ends
    early) and ``.error`` (what is wrong, naming the file; None for a sound bag).

    A sound bag is read by rosbags. If rosbags refuses it (file cut short,
    metadata.yaml missing, ...), the .mcap file is parsed tolerantly instead:
    every complete message before the first incomplete record is returned,
    including the readable part of a chunk that was cut; ``.truncated`` and
    ``.error`` are known at once. That fallback holds the file in memory.
    """

    def __init__(self, path, topics: Iterable[str] | None = None):
        self.path = Path(path)
        self._wanted = None if topics is None else set(topics)
        self.truncated = False
        self.error: str | None = None
        self.counts: dict[str, int] = {}
        self._records: list[Record] | None = None
        try:
            with Reader(self.path) as reader:
                self.topics = {c.topic: c.msgtype for c in reader.connections if self._keep(c.topic)}
        except Exception as exc:
            self._read_tolerant(exc)

    def _keep(self, topic: str) -> bool:
        return self._wanted is None or topic in self._wanted

    def _read_tolerant(self, cause: Exception) -> None:
        files = [self.path] if self.path.is_file() else sorted(self.path.glob("*.mcap"))
        if not files:
            raise FileNotFoundError(errno.ENOENT, f"no .mcap file in bag ({cause})", str(self.path))
        self._records, problems = [], []
        for mcap in files:
            records, problem = scan_mcap(mcap)
            self._records += [r for r in records if self._keep(r.topic)]
            if problem:
                problems.append(f"{mcap}: {problem}")
        self._records.sort(key=lambda r: r.t_ns)  # stable: file order within equal times
        self.topics = {r.topic: r.msgtype for r in self._records}
        self.truncated = bool(problems)
        if problems:
            self.error = "; ".join(problems) + f" (rosbags: {cause})"
        elif self.path.is_dir():
            self.error = f"{self.path}: read without rosbags ({cause})"

    def _read_rosbags(self) -> Iterator[Record]:
        with Reader(self.path) as reader:
            connections = [c for c in reader.connections if self._keep(c.topic)]
            if not connections:  # rosbags reads every topic when given none
                return
            try:
                for conn, t_ns, raw in reader.messages(connections=connections):
                    yield Record(conn.topic, conn.msgtype, t_ns, bytes(raw))
            except Exception as exc:
                self.truncated = True
                files = ", ".join(map(str, sorted(self.path.glob("*.mcap"))))
                self.error = f"{files}: stopped reading: {exc}"

    def __iter__(self) -> Iterator[Record]:
        self.counts = {}
        source = iter(self._records) if self._records is not None else self._read_rosbags()
        for record in source:
            self.counts[record.topic] = self.counts.get(record.topic, 0) + 1
            yield record


def read_bag(path, topics: Iterable[str] | None = None) -> BagReader:
    """Open a bag directory (or a bare .mcap file) for reading; see :class:`BagReader`."""
    return BagReader(path, topics)


# --- tolerant MCAP parser ----------------------------------------------------
# MCAP: magic, then records (opcode u8, body length u64 LE, body); all integers
# little-endian, strings u32-length-prefixed UTF-8. https://mcap.dev/spec

MCAP_MAGIC = b"\x89MCAP0\r\n"
_OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 0x02, 0x03, 0x04, 0x05, 0x06
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")
_CHUNK_HEAD = struct.Struct("<QQQI")  # start, end, uncompressed size, crc


def _string(buf, pos: int) -> tuple[str, int]:
    (n,) = _U32.unpack_from(buf, pos)
    return bytes(buf[pos + 4 : pos + 4 + n]).decode(), pos + 4 + n


def _decompress(data, compression: str) -> bytes:
    """Decompress chunk records; a cut-off stream yields what it can."""
    if compression == "":
        return data
    if compression == "zstd":
        try:
            from compression import zstd  # Python >= 3.14
        except ImportError:
            from backports import zstd  # rosbags dependency
        return zstd.ZstdDecompressor().decompress(bytes(data))
    if compression == "lz4":
        from lz4.frame import LZ4FrameDecompressor

        return LZ4FrameDecompressor().decompress(bytes(data))
    raise ValueError(f"unsupported chunk compression {compression!r}")


class _Scan:
    def __init__(self):
        self.schemas: dict[int, str] = {}  # schema id -> type name
        self.channels: dict[int, tuple[str, str]] = {}  # channel id -> (topic, type)
        self.records: list[Record] = []
        self.damage: list[str] = []  # complete chunks whose content did not parse
        self.footer = False

    def walk(self, buf, pos: int = 0) -> str | None:
        """Parse records from ``pos``; None at a clean end, else where it broke."""
        while pos < len(buf) and not self.footer:
            if pos + 9 > len(buf):
                return f"incomplete record header at offset {pos}"
            op, (length,) = buf[pos], _U64.unpack_from(buf, pos + 1)
            body = buf[pos + 9 : pos + 9 + length]
            if len(body) < length:
                if op == _OP_CHUNK:
                    self.chunk(body)
                return f"record 0x{op:02x} at offset {pos} cut short ({len(body)} of {length} bytes)"
            self.record(op, body)
            pos += 9 + length
        return None

    def record(self, op: int, body) -> None:
        if op == _OP_FOOTER:
            self.footer = True
        elif op == _OP_SCHEMA:
            (sid,) = _U16.unpack_from(body, 0)
            self.schemas[sid] = _string(body, 2)[0]
        elif op == _OP_CHANNEL:
            cid, sid = struct.unpack_from("<HH", body, 0)
            self.channels[cid] = (_string(body, 4)[0], self.schemas.get(sid, ""))
        elif op == _OP_MESSAGE:
            cid, _seq, log_time = struct.unpack_from("<HIQ", body, 0)
            if cid in self.channels:
                topic, msgtype = self.channels[cid]
                self.records.append(Record(topic, msgtype, log_time, bytes(body[22:])))
        elif op == _OP_CHUNK:
            problem = self.chunk(body)
            if problem:
                self.damage.append(f"chunk: {problem}")

    def chunk(self, body) -> str | None:
        """Read a chunk's records; for a cut chunk, the complete ones."""
        if len(body) < _CHUNK_HEAD.size + 4:
            return "chunk header cut short"
        compression, pos = _string(body, _CHUNK_HEAD.size)
        if pos + 8 > len(body):
            return "chunk header cut short"
        inner = _decompress(body[pos + 8 : pos + 8 + _U64.unpack_from(body, pos)[0]], compression)
        problem = self.walk(memoryview(inner))
        self.footer = False  # only the top level has a footer
        return problem


def scan_mcap(path) -> tuple[list[Record], str | None]:
    """Tolerantly read all messages of one .mcap file, in file order.

    Returns ``(records, problem)``: problem is None for a complete file (footer
    reached), else a description of where the data ends or is damaged.
    """
    data = memoryview(Path(path).read_bytes())
    if bytes(data[:8]) != MCAP_MAGIC:
        cut = len(data) < 8 and MCAP_MAGIC.startswith(bytes(data))
        return [], "file ends inside the MCAP magic" if cut else "not an MCAP file (bad magic)"
    scan = _Scan()
    try:
        problem = scan.walk(data, 8)
    except Exception as exc:  # damaged bytes: keep what was read before them
        problem = f"damaged record: {exc}"
    if problem is None and not scan.footer:
        problem = f"no MCAP footer, file ends at offset {len(data)}"
    problems = scan.damage + ([problem] if problem else [])
    return scan.records, "; ".join(problems) or None
