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

Pure Python (``mcap`` writes, rosbags reads), no rclpy: usable offline and
in tests. Bags are written as ``ros2 bag record`` (Jazzy, MCAP storage) writes
them: offered QoS profiles per topic, chunk CRCs, ``ros_distro: jazzy``
(:class:`BagWriter`); the player offers the recorded QoS again
(:func:`playback_qos`: transient local stays transient local). A bag cut short
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

from rosbags.rosbag2 import Reader
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


# --- rosbag2 conventions (Jazzy) ----------------------------------------------
ROS_DISTRO = "jazzy"
METADATA_VERSION = 9          # rosbag2 metadata.yaml version of Jazzy
INFINITE = {"sec": 9223372036, "nsec": 854775807}   # rmw "infinite" duration as rosbag2 writes it


def qos_profile(reliability: str = "reliable", durability: str = "volatile", history: str = "keep_last",
                depth: int = 0, deadline=None, lifespan=None, liveliness: str = "automatic",
                liveliness_lease_duration=None, avoid_ros_namespace_conventions: bool = False) -> dict:
    """One offered QoS profile as rosbag2 (metadata version 9) writes it:
    lower-case policy names, durations as {sec, nsec}."""
    return {"history": history, "depth": int(depth), "reliability": reliability, "durability": durability,
            "deadline": dict(deadline or INFINITE), "lifespan": dict(lifespan or INFINITE),
            "liveliness": liveliness,
            "liveliness_lease_duration": dict(liveliness_lease_duration or INFINITE),
            "avoid_ros_namespace_conventions": bool(avoid_ros_namespace_conventions)}


def playback_qos(profiles) -> dict:
    """QoS a player offers for a recorded topic, adapted from the publishers'
    offered profiles as ``ros2 bag play`` does: reliable if every publisher was
    reliable (else best effort), transient local if every one was transient
    local (else volatile), depth the largest recorded depth. Unknown (no
    profile recorded) -> reliable, volatile, depth 0 (caller's default)."""
    profiles = [p for p in (profiles or []) if isinstance(p, dict)]
    if not profiles:
        return {"reliability": "reliable", "durability": "volatile", "depth": 0}
    reliable = all(p.get("reliability") == "reliable" for p in profiles)
    latched = all(p.get("durability") == "transient_local" for p in profiles)
    return {"reliability": "reliable" if reliable else "best_effort",
            "durability": "transient_local" if latched else "volatile",
            "depth": max(int(p.get("depth", 0)) for p in profiles)}


class BagWriter:
    """Write already serialized (CDR) messages into a new rosbag2/MCAP bag, as
    ``ros2 bag record -s mcap`` (Jazzy) lays it out: MCAP profile ``ros2``,
    schemas ``ros2msg`` with the full message definition, channels ``cdr`` with
    the publishers' ``offered_qos_profiles`` and ``topic_type_hash`` (RIHS01),
    chunk CRCs and a data-section CRC (the ``mcap`` library's writer), a
    ``rosbag2`` metadata record, and ``metadata.yaml`` (version 9, ``ros_distro:
    jazzy``) with the offered QoS profiles per topic.

    ``compression``: None (uncompressed chunks, rosbag2's default) or ``"zstd"``
    (zstd-compressed MCAP chunks; metadata.yaml and the file name stay as
    without compression). Refuses an existing path (FileExistsError). Use as a
    context manager, or call :meth:`close` to write the MCAP summary and
    metadata.yaml.
    """

    def __init__(self, path, compression: str | None = None, chunk_size: int = 1 << 20):
        from mcap.writer import CompressionType, Writer
        self.path = Path(path)
        kinds = {None: CompressionType.NONE, "zstd": CompressionType.ZSTD}
        if compression not in kinds:
            raise ValueError(f"unsupported compression {compression!r} (None or 'zstd')")
        try:
            self.path.mkdir(parents=True)
        except FileExistsError:
            raise FileExistsError(errno.EEXIST, "bag exists already, not overwriting", str(self.path)) from None
        self.file_path = self.path / f"{self.path.name}.mcap"
        self._file = self.file_path.open("xb")
        self._mcap = Writer(self._file, chunk_size=chunk_size, compression=kinds[compression],
                            enable_crcs=True, enable_data_crcs=True)
        self._mcap.start(profile="ros2", library=f"hyper-nav rosbag2 writer (mcap-python {_version('mcap')})")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, tuple[int, str]] = {}       # topic -> (channel id, msgtype)
        self.qos: dict[str, list[dict]] = {}
        self._hash: dict[str, str] = {}
        self._seq: dict[str, int] = {}
        self.counts: dict[str, int] = {}
        self._t_min, self._t_max = None, None
        self._closed = False

    def add_topic(self, topic: str, msgtype: str, offered_qos_profiles=()) -> None:
        """Declare a topic with the QoS profiles its publishers offer (see
        :func:`qos_profile`); :meth:`write` declares unknown topics itself
        (without profiles)."""
        if topic in self._channels:
            if self._channels[topic][1] != msgtype:
                raise ValueError(f"{topic}: recorded as {self._channels[topic][1]}, not {msgtype}")
            return
        store = typestore()
        if msgtype not in self._schemas:
            msgdef, _ = store.generate_msgdef(msgtype, ros_version=2)
            self._schemas[msgtype] = self._mcap.register_schema(msgtype, "ros2msg", msgdef.encode())
        self._hash[topic] = store.hash_rihs01(msgtype)
        self.qos[topic] = [dict(p) for p in offered_qos_profiles]
        meta = {"offered_qos_profiles": _yaml_dump(self.qos[topic]) if self.qos[topic] else "",
                "topic_type_hash": self._hash[topic]}
        cid = self._mcap.register_channel(topic, "cdr", self._schemas[msgtype], meta)
        self._channels[topic] = (cid, msgtype)
        self.counts.setdefault(topic, 0)

    def write(self, topic: str, msgtype: str, t_ns: int, raw: bytes, publish_t_ns: int | None = None) -> None:
        """Append one message: CDR bytes ``raw`` of type ``msgtype`` logged
        (received) at ``t_ns`` and published at ``publish_t_ns`` (default t_ns), in ns."""
        if topic not in self._channels:
            self.add_topic(topic, msgtype)
        cid, _ = self._channels[topic]
        t_ns = int(t_ns)
        self._mcap.add_message(cid, log_time=t_ns, data=bytes(raw),
                               publish_time=t_ns if publish_t_ns is None else int(publish_t_ns),
                               sequence=self._seq.get(topic, 0))
        self._seq[topic] = self._seq.get(topic, 0) + 1
        self.counts[topic] += 1
        self._t_min = t_ns if self._t_min is None else min(self._t_min, t_ns)
        self._t_max = t_ns if self._t_max is None else max(self._t_max, t_ns)

    def flush(self) -> None:
        """End the chunk in progress and push it to disk, so a crash loses only
        what came after (the tolerant reader recovers every flushed chunk)."""
        if not self._closed:
            self._mcap.flush()

    def metadata(self) -> dict:
        """The rosbag2 bag information (``metadata.yaml`` content)."""
        return rosbag2_metadata({t: (mt, self.qos.get(t, []), self._hash[t]) for t, (_, mt) in self._channels.items()},
                                self.counts, self._t_min, self._t_max, self.file_path.name)

    def close(self) -> None:
        """Finish the MCAP file (rosbag2 metadata record, summary with CRCs,
        footer) and write metadata.yaml. Idempotent."""
        if self._closed:
            return
        info = self.metadata()
        self._mcap.flush()
        self._mcap.add_metadata("rosbag2", {"serialized_metadata": _yaml_dump(info["rosbag2_bagfile_information"])})
        self._mcap.finish()
        self._file.close()
        self._closed = True
        tmp = self.path / "metadata.yaml.tmp"
        tmp.write_text(_yaml_dump(info))
        tmp.replace(self.path / "metadata.yaml")

    def abort(self) -> None:
        """Close the file without summary or metadata.yaml (what a killed
        recorder leaves behind: flushed chunks only)."""
        if not self._closed:
            self._file.close()
            self._closed = True

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def rosbag2_metadata(topics: dict, counts: dict, t_min: int | None, t_max: int | None, file_name: str) -> dict:
    """``metadata.yaml`` content (rosbag2 Jazzy, version 9) of one MCAP file:
    ``topics`` {topic: (msgtype, offered QoS profiles, type hash)}, message
    counts per topic, first and last log time (ns)."""
    start = t_min or 0
    duration = (t_max - t_min) if t_min is not None else 0
    n = sum(counts.values())
    entries = [{"topic_metadata": {"name": t, "type": mt, "serialization_format": "cdr",
                                   "offered_qos_profiles": list(qos), "type_description_hash": h},
                "message_count": counts.get(t, 0)} for t, (mt, qos, h) in topics.items()]
    return {"rosbag2_bagfile_information": {
        "version": METADATA_VERSION, "storage_identifier": "mcap",
        "duration": {"nanoseconds": duration}, "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": n, "topics_with_message_count": entries,
        "compression_format": "", "compression_mode": "",
        "relative_file_paths": [file_name],
        "files": [{"path": file_name, "starting_time": {"nanoseconds_since_epoch": start},
                   "duration": {"nanoseconds": duration}, "message_count": n}],
        "custom_data": None, "ros_distro": ROS_DISTRO}}


def _yaml_dump(data) -> str:
    import yaml
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=False)


def _version(dist: str) -> str:
    from importlib.metadata import version
    try:
        return version(dist)
    except Exception:  # not installed as a distribution
        return "unknown"


class BagReader:
    """Iterate over a bag's messages as :class:`Record` in log-time order.

    ``topics``: iterable of topic names to keep (None = all). ``.topics`` maps
    topic -> msgtype and is known after construction. After a full iteration:
    ``.counts`` (topic -> records yielded), ``.truncated`` (the MCAP data ends
    early) and ``.error`` (what is wrong, naming the file; None for a sound bag).

    ``.qos`` maps topic -> the offered QoS profiles recorded for it (list of
    :func:`qos_profile` dicts; empty when the bag has none).

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
        self.qos: dict[str, list[dict]] = {}
        try:
            with Reader(self.path) as reader:
                self.topics = {c.topic: c.msgtype for c in reader.connections if self._keep(c.topic)}
                from rosbags.rosbag2.metadata import dump_qos_v9
                for c in reader.connections:
                    if self._keep(c.topic):
                        self.qos[c.topic] = [dict(q) for q in dump_qos_v9(list(c.ext.offered_qos_profiles))]
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
            records, problem = scan_mcap(mcap, self.qos)
            self._records += [r for r in records if self._keep(r.topic)]
            if problem:
                problems.append(f"{mcap}: {problem}")
        self._records.sort(key=lambda r: r.t_ns)  # stable: file order within equal times
        self.topics = {r.topic: r.msgtype for r in self._records}
        self.qos = {t: q for t, q in self.qos.items() if t in self.topics}
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
        self.qos: dict[str, list[dict]] = {}  # topic -> offered QoS profiles (channel metadata)
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
            topic, pos = _string(body, 4)
            self.channels[cid] = (topic, self.schemas.get(sid, ""))
            self.qos[topic] = _channel_qos(body, _string(body, pos)[1])
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


def _channel_qos(body, pos: int) -> list[dict]:
    """``offered_qos_profiles`` of a channel record's metadata map (rosbag2
    writes a YAML list), [] if absent or unreadable."""
    try:
        (n,) = _U32.unpack_from(body, pos)
        end, pos = pos + 4 + n, pos + 4
        while pos < end:
            key, pos = _string(body, pos)
            value, pos = _string(body, pos)
            if key == "offered_qos_profiles":
                import yaml
                profiles = yaml.safe_load(value) if value.strip() else []
                return [p for p in profiles if isinstance(p, dict)] if isinstance(profiles, list) else []
    except Exception:  # damaged metadata: the messages still count
        pass
    return []


def scan_mcap(path, qos: dict | None = None) -> tuple[list[Record], str | None]:
    """Tolerantly read all messages of one .mcap file, in file order.

    Returns ``(records, problem)``: problem is None for a complete file (footer
    reached), else a description of where the data ends or is damaged. The
    offered QoS profiles of the channels found are added to ``qos``.
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
    if qos is not None:
        qos.update(scan.qos)
    return scan.records, "; ".join(problems) or None
