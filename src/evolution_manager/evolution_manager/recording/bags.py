"""Recording to rosbag2 bags with MCAP storage, reading them back, and recovering a bag whose writer was
killed.

Bags are written with ``rosbags`` (pure Python): rosbag2 format version 9, MCAP storage, CDR serialisation,
and the message definitions of ``swarm_msgs`` embedded, so ``ros2 bag``, Foxglove and the ``mcap`` tools can
open them. When a bag is closed its MCAP file is rewritten as ``ros2 bag record`` writes one
(``as_rosbag2_mcap``): each channel's ``topic_type_hash`` beside its ``offered_qos_profiles``, and the ROS
distribution (``ROS_DISTRO``, else the wheels', ``kilted``) in place of ``rosbags`` as ``ros_distro``, in the
``rosbag2`` metadata record and in ``metadata.yaml``. Nothing here imports ``rclpy``: nodes hand the recorder
the CDR bytes they received (``raw=True`` subscriptions), and the manager hands it message objects of the
``rosbags`` typestore.

A writer killed with SIGKILL leaves an MCAP file without its summary and no ``metadata.yaml``; ``recover_bag``
reads such a file as a stream and writes a whole bag holding every message of the chunks that were flushed.
"""

from __future__ import annotations

import binascii
import os
import shutil
import struct
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, DataEnd, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from rosbags.interfaces import (
    Connection,
    MessageDefinitionFormat,
    Nodetype,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from evolution_manager.errors import BagError
from evolution_manager.processes import Lock, exclusive_lock, is_locked, lock_holder, lock_path_for
from swarm_ros.safe_paths import describe

INTERFACE_PACKAGE = "swarm_msgs"

LATCHED_TOPICS = ("trial_start", "markers", "tf_static", "faults")
"""The last names of the simulator's transient-local (latched) topics; every other topic is volatile."""


def is_latched(topic: str) -> bool:
    """Whether ``topic`` (an absolute name) is one of the simulator's transient-local topics."""
    return topic.rsplit("/", 1)[-1] in LATCHED_TOPICS


_UNSET = QosTime(sec=0, nsec=0)  # rosbag2's "default" duration, as `ros2 bag record` writes it


def offered_qos(topic: str) -> Qos:
    """The QoS the graph's publishers offer on ``topic`` (swarm_ros.qos RELIABLE, or LATCHED for latched
    topics), in the form bags record it, so that ``ros2 bag play`` republishes latched topics latched."""
    latched = is_latched(topic)
    return Qos(
        history=QosHistory.KEEP_LAST,
        depth=1 if latched else 1000,  # swarm_ros.qos LATCHED and RELIABLE (a test checks)
        reliability=QosReliability.RELIABLE,
        durability=QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
        deadline=_UNSET,
        lifespan=_UNSET,
        liveliness=QosLiveliness.AUTOMATIC,
        liveliness_lease_duration=_UNSET,
        avoid_ros_namespace_conventions=False,
    )


def bag_lock(path: Path) -> Path:
    """The lock a recorder holds while it writes the bag at ``path``. It lives outside the bag folder (in
    the machine's temporary folder, named by the bag's full path), so that a killed recorder leaves nothing
    in the folder but the bag; lock files are never deleted (see ``exclusive_lock``)."""
    return lock_path_for(Path(path), "bag")


def swarm_msgs_definitions() -> dict[str, str]:
    """The ``.msg`` definitions of swarm_msgs, by type name (``swarm_msgs/msg/WheelCommand``), read from the
    installed package (found on ``AMENT_PREFIX_PATH``)."""
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        msg_dir = Path(prefix) / "share" / INTERFACE_PACKAGE / "msg"
        if msg_dir.is_dir():
            return {f"{INTERFACE_PACKAGE}/msg/{f.stem}": f.read_text() for f in sorted(msg_dir.glob("*.msg"))}
    raise BagError(
        f"the {INTERFACE_PACKAGE} message definitions were not found on AMENT_PREFIX_PATH: "
        "source the workspace (ws/env.sh) or run through ws/run"
    )


def swarm_typestore() -> Typestore:
    """A ROS 2 Kilted typestore that also knows every swarm_msgs message."""
    store = get_typestore(Stores.ROS2_KILTED)
    types: dict[str, Any] = {}
    for name, text in swarm_msgs_definitions().items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


_NUMBER_TYPES: dict[str, type] = {
    name: getattr(np, name)
    for name in (
        "float32",
        "float64",
        "int8",
        "uint8",
        "int16",
        "uint16",
        "int32",
        "uint32",
        "int64",
        "uint64",
    )
}
"""The ROS number types by name, as numpy's (rosbags serializes sequences of them from numpy arrays)."""


WHEELS_DISTRO = "kilted"
"""The ROS 2 distribution of the PyPI wheels this workspace runs on (``ws/requirements.in``)."""


def ros_distro() -> str:
    """The ROS distribution bags name: ``ROS_DISTRO`` where a ROS 2 install set it, else the wheels'."""
    return os.environ.get("ROS_DISTRO") or WHEELS_DISTRO


def as_rosbag2_mcap(bag: Path, distro: str) -> None:
    """Rewrite the MCAP file and ``metadata.yaml`` of the closed bag ``bag`` as rosbag2's own MCAP storage
    writes them: each channel's metadata holds ``topic_type_hash`` (the type's RIHS01 hash, which rosbags
    keeps only in ``metadata.yaml``) beside ``offered_qos_profiles``, and ``ros_distro`` is ``distro``
    (rosbags writes ``rosbags``) in ``metadata.yaml`` and in the ``rosbag2`` metadata record, which also gets
    the ``ros_distro`` key. Messages, channels, schemas and their order are kept; chunks stay uncompressed,
    with CRCs."""
    metadata_file = bag / "metadata.yaml"
    text = metadata_file.read_text()
    hashes = {
        topic["topic_metadata"]["name"]: topic["topic_metadata"].get("type_description_hash", "")
        for topic in _yaml_topics(text)
    }
    text = text.replace("ros_distro: rosbags", f"ros_distro: {distro}")
    for file in sorted(bag.glob("*.mcap")):
        rewritten = file.with_name(file.name + ".tmp")
        with file.open("rb") as source, rewritten.open("wb") as sink:
            reader = make_reader(source)
            header = reader.get_header()
            summary = reader.get_summary()
            assert summary is not None  # rosbags writes a summary
            writer = McapWriter(sink, compression=CompressionType.NONE)
            writer.start(profile=header.profile, library=header.library)
            schema_ids = {
                schema.id: writer.register_schema(schema.name, schema.encoding, schema.data)
                for schema in sorted(summary.schemas.values(), key=lambda s: s.id)
            }
            channel_ids = {}
            for channel in sorted(summary.channels.values(), key=lambda c: c.id):
                metadata = dict(channel.metadata)
                metadata["topic_type_hash"] = hashes.get(channel.topic, "")
                channel_ids[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schema_ids[channel.schema_id], metadata
                )
            for _, channel, message in reader.iter_messages(log_time_order=False):
                writer.add_message(
                    channel_ids[channel.id],
                    message.log_time,
                    message.data,
                    message.publish_time,
                    message.sequence,
                )
            for record in reader.iter_metadata():
                data = dict(record.metadata)
                if record.name == "rosbag2":
                    data["serialized_metadata"] = data.get("serialized_metadata", "").replace(
                        "ros_distro: rosbags", f"ros_distro: {distro}"
                    )
                    data["ros_distro"] = distro
                writer.add_metadata(record.name, data)
            writer.finish()
        rewritten.replace(file)
    temporary = metadata_file.with_name("metadata.yaml.tmp")
    temporary.write_text(text)
    temporary.replace(metadata_file)


def _yaml_topics(text: str) -> list[Any]:
    """The ``topics_with_message_count`` of a ``metadata.yaml`` text."""
    document = yaml.safe_load(text)
    return list(document["rosbag2_bagfile_information"]["topics_with_message_count"])


class BagRecorder:
    """Write messages to a new rosbag2 bag with MCAP storage.

    Use as a context manager; the bag is whole (index and ``metadata.yaml`` written) once the context exits,
    also when the body raised. To stop a recording on a signal, set a flag in the signal handler and leave the
    context normally: a process killed inside ``write`` loses only the unflushed tail (see ``recover_bag``).
    """

    def __init__(self, path: Path | str, typestore: Typestore | None = None) -> None:
        self.path = Path(path)
        check_new_bag(self.path)
        self.typestore = typestore or swarm_typestore()
        self._writer: Writer | None = None
        self._lock: Lock | None = None
        self._connections: dict[str, Any] = {}
        self.count = 0

    def __enter__(self) -> BagRecorder:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
            self._writer.open()  # creates the directory, or fails if another writer did
        except OSError as error:  # a place under a file said as such (it was "File exists")
            self._writer = None
            raise BagError(f"cannot write a bag at {describe(self.path, error)}") from None
        except Exception as error:  # rosbags' WriterError: the directory appeared meanwhile
            self._writer = None
            check_new_bag(self.path)
            raise BagError(f"cannot write a bag at {self.path}: {error}") from None
        self._lock = exclusive_lock(bag_lock(self.path), f"the bag {self.path}")
        return self

    def __exit__(self, *exc_info: object) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None
            as_rosbag2_mcap(self.path, ros_distro())
            for file in sorted(self.path.glob("*.mcap")):  # rosbags writes none: a flipped bit would pass
                add_crcs(file)
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    def flush(self, sync: bool = False) -> None:
        """Put every message written so far on disk as a whole MCAP chunk, so that a kill from now on loses
        none of them (``recover`` reads them back); with ``sync``, also wait for the disk."""
        # rosbags' MCAP writer (McapWriter) keeps the pending chunk and the file; its protocol type does not
        # show them, hence Any.
        storage: Any = None if self._writer is None else self._writer.storage
        if storage is None:
            return
        # rosbags closes a chunk only at 1 MiB or at the end; close the pending one now.
        if storage.chunk.bio.tell():
            storage.close_chunk()
        storage.bio.flush()
        if sync:
            os.fsync(storage.bio.fileno())

    def write_cdr(self, topic: str, msgtype: str, timestamp_ns: int, data: bytes | memoryview) -> None:
        """Record one message given as CDR bytes (as an rclpy ``raw=True`` subscription delivers it)."""
        if self._writer is None:
            raise BagError("the recorder is not open: use it as a context manager")
        connection = self._connections.get(topic)
        if connection is None:
            connection = self._writer.add_connection(
                topic, msgtype, typestore=self.typestore, offered_qos_profiles=[offered_qos(topic)]
            )
            self._connections[topic] = connection
        elif connection.msgtype != msgtype:
            raise BagError(f"topic {topic} is recorded as {connection.msgtype}, not {msgtype}")
        self._writer.write(connection, timestamp_ns, data)
        self.count += 1

    def write(self, topic: str, msg: Any, timestamp_ns: int) -> None:
        """Record one message object of this recorder's typestore (e.g. ``recorder.message(...)``)."""
        msgtype = msg.__msgtype__
        self.write_cdr(topic, msgtype, timestamp_ns, self.typestore.serialize_cdr(msg, msgtype))

    def message(self, msgtype: str, **fields: Any) -> Any:
        """A message object of type ``msgtype`` (e.g. ``swarm_msgs/msg/EvaluationResult``). A sequence or
        array of numbers may be given as a list, as rclpy takes it: it becomes the numpy array rosbags
        serializes."""
        for name, (kind, detail) in self.typestore.fielddefs[msgtype][1]:
            value = fields.get(name)
            if kind in (Nodetype.SEQUENCE, Nodetype.ARRAY) and isinstance(value, (list, tuple)):
                element: Any = detail[0]  # (kind, (type name, bound)) of the elements
                if element[0] == Nodetype.BASE and element[1][0] in _NUMBER_TYPES:
                    fields[name] = np.asarray(value, dtype=_NUMBER_TYPES[element[1][0]])
        return self.typestore.types[msgtype](**fields)


@dataclass(frozen=True)
class BagMessage:
    """One message read back from a bag."""

    topic: str
    msgtype: str
    timestamp_ns: int
    data: bytes
    message: Any


_CHUNK, _DATA_END = 0x06, 0x0F


def add_crcs(file: Path) -> None:
    """Write into the MCAP ``file``, in place, the CRC-32 of each uncompressed chunk's records and of the
    data section, where the writer left 0 ("no CRC"; rosbags does), so that readers that validate CRCs
    (``check_crcs``, the ``mcap`` tools) notice a changed byte. Nothing else of the file changes."""
    data = bytearray(Path(file).read_bytes())
    changed = False
    position = 8  # after the magic
    while position + 9 <= len(data):
        opcode = data[position]
        (length,) = struct.unpack_from("<Q", data, position + 1)
        content = position + 9
        if opcode == _CHUNK:
            (crc, name_length) = struct.unpack_from("<II", data, content + 24)
            compression = bytes(data[content + 32 : content + 32 + name_length])
            (records_length,) = struct.unpack_from("<Q", data, content + 32 + name_length)
            records_at = content + 32 + name_length + 8
            if crc == 0 and compression == b"":
                records = data[records_at : records_at + records_length]
                struct.pack_into("<I", data, content + 24, binascii.crc32(records))
                changed = True
        elif opcode == _DATA_END:
            (crc,) = struct.unpack_from("<I", data, content)
            if crc == 0:  # over the whole data section, the chunks' CRCs just written included
                struct.pack_into("<I", data, content, binascii.crc32(data[:position]))
                changed = True
            break
        position = content + length
    if changed:
        with open(file, "r+b") as handle:
            handle.write(data)


def check_crcs(path: Path | str) -> int:
    """Validate the CRCs of every MCAP file of the bag at ``path`` (each chunk's and the data section's, where
    the file has them); return how many CRCs were checked; ``BagError`` naming the file for one that does not
    match (a changed byte) or a file that cannot be read whole."""
    checked = 0
    for file in sorted(Path(path).glob("*.mcap")):
        try:
            with file.open("rb") as stream:
                for record in StreamReader(stream, emit_chunks=True, validate_crcs=True).records:
                    if isinstance(record, Chunk) and record.uncompressed_crc:
                        _chunk_records(record)  # StreamReader checks a chunk's CRC as it opens it
                        checked += 1
                    elif isinstance(record, DataEnd) and record.data_section_crc:
                        checked += 1
        except (McapError, ValueError, EOFError, OSError, struct.error) as error:
            raise BagError(f"{file} is damaged: {error}") from None
    return checked


def _chunk_records(chunk: Any) -> None:
    """Raise McapError unless ``chunk``'s records match its CRC."""
    if chunk.compression == "" and binascii.crc32(chunk.data) != chunk.uncompressed_crc:
        found = binascii.crc32(chunk.data)
        raise McapError(f"a chunk's CRC is {chunk.uncompressed_crc:#010x}, its records' {found:#010x}")


def read_bag(path: Path | str, typestore: Typestore | None = None) -> Iterator[BagMessage]:
    """Every message of a whole bag, in timestamp order, deserialised with ``typestore``.

    Raises ``BagError`` at once (not on the first iteration) when ``path`` holds no whole bag."""
    path = Path(path)
    check_bag(path)
    return _messages(path, typestore or swarm_typestore())


def check_new_bag(path: Path) -> None:
    """Raise ``BagError`` when ``path`` cannot be a new bag: it exists (naming the process that is writing it,
    if one is), or a symbolic link stands there (a dangling one too: its target would be made), or it lies
    under a file."""
    if path.is_symlink():
        raise BagError(
            f"{path} is a symbolic link: refusing to write a bag through it; choose a new bag directory"
        )
    if not path.exists():
        for parent in path.parents:
            if parent.exists():
                if not parent.is_dir():
                    raise BagError(f"cannot write a bag at {path}: {parent} is a file, not a folder")
                break
        return
    lock = bag_lock(path)
    if is_locked(lock):
        holder = lock_holder(lock)
        raise BagError(f"{path} is being written by {f'process {holder}' if holder else 'another process'}")
    raise BagError(f"refusing to overwrite {path}: choose a new bag directory")


def check_not_being_written(path: Path) -> None:
    """Raise ``BagError`` when a live recorder still writes the bag at ``path``."""
    lock = bag_lock(path)
    if is_locked(lock):
        holder = lock_holder(lock)
        raise BagError(
            f"{path} is still being written by {f'process {holder}' if holder else 'another process'}: "
            "wait for it to end"
        )


def check_bag(path: Path) -> None:
    """Raise ``BagError`` saying what is wrong when ``path`` is not a whole rosbag2 bag."""
    if not path.exists():
        raise BagError(f"no bag at {path}")
    if not (path / "metadata.yaml").exists():
        raise BagError(
            f"{path} is not a whole rosbag2 bag (no metadata.yaml): if its recorder was killed, run "
            f"`ws/run evolution_manager recover {path} NEW_BAG`"
        )


def topic_counts(path: Path) -> dict[str, int]:
    """How many messages each topic of the whole bag at ``path`` holds (from its index, reading none)."""
    check_bag(path)
    try:
        with Reader(path) as reader:
            counts: dict[str, int] = {}
            for connection in reader.connections:
                counts[connection.topic] = counts.get(connection.topic, 0) + connection.msgcount
            return counts
    except Exception as error:  # rosbags' ReaderError, a damaged metadata.yaml
        raise BagError(f"{path} is not a readable bag ({type(error).__name__}: {error})") from None


def _as_written(connections: list[Connection], store: Typestore) -> Typestore:
    """``store``, but with the bag's own definitions of its message types where it holds them: a bag written
    before a message gained fields (the food kinds' arrays, say) reads back as it was written, and a reader
    asks ``getattr`` for what such a message lacks."""
    written: dict[str, Any] = {}
    for connection in connections:
        if connection.msgdef.format == MessageDefinitionFormat.MSG and connection.msgdef.data:
            written.update(get_types_from_msg(connection.msgdef.data, connection.msgtype))
    if all(store.fielddefs.get(name) == fields for name, fields in written.items()):
        return store
    own = get_typestore(Stores.EMPTY)
    own.register(written)
    own.register({name: fields for name, fields in store.fielddefs.items() if name not in written})
    return own


def _messages(path: Path, store: Typestore) -> Iterator[BagMessage]:
    try:
        with Reader(path) as reader:
            store = _as_written(list(reader.connections), store)
            for connection, timestamp, data in reader.messages():
                message = store.deserialize_cdr(data, connection.msgtype)
                yield BagMessage(connection.topic, connection.msgtype, timestamp, bytes(data), message)
    except BagError:
        raise
    except Exception as error:  # rosbags' ReaderError, a truncated MCAP file, a damaged metadata.yaml
        raise BagError(f"{path} is not a readable bag ({type(error).__name__}: {error})") from None


def stream_messages(damaged: Path) -> Iterator[tuple[str, str, int, bytes]]:
    """(topic, type, timestamp, CDR bytes) of every message that reached the disk in the MCAP file(s) of a bag
    whose writer may have been killed, in file order; a truncated tail is skipped."""
    damaged = Path(damaged)
    files = sorted(damaged.glob("*.mcap")) if damaged.is_dir() else [damaged]
    for file in files:
        schemas: dict[int, str] = {}
        channels: dict[int, tuple[str, str]] = {}
        with file.open("rb") as stream:
            try:
                # CRCs checked where the file has them: a damaged chunk ends what is recovered
                for record in StreamReader(stream, emit_chunks=False, validate_crcs=True).records:
                    if isinstance(record, Schema):
                        schemas[record.id] = record.name
                    elif isinstance(record, Channel):
                        channels[record.id] = (record.topic, schemas.get(record.schema_id, ""))
                    elif isinstance(record, Message) and record.channel_id in channels:
                        topic, msgtype = channels[record.channel_id]
                        yield topic, msgtype, record.log_time, bytes(record.data)
            except (McapError, EOFError, ValueError, OSError, AssertionError, struct.error):
                pass  # the truncated tail: everything before it is kept


def promised_messages(path: Path | str) -> int | None:
    """How many messages the ``metadata.yaml`` of the bag at ``path`` counts, or None (no readable count)."""
    try:
        document = yaml.safe_load((Path(path) / "metadata.yaml").read_text())
        count = document["rosbag2_bagfile_information"]["message_count"]
    except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError):
        return None
    return count if isinstance(count, int) and not isinstance(count, bool) and count >= 0 else None


def recover_bag(damaged: Path | str, recovered: Path | str) -> int:
    """Write a whole bag at ``recovered`` from every message that reached the disk in the MCAP file(s) of a
    bag whose writer was killed; return the number of messages recovered. Raises ``BagError`` when nothing
    could be recovered from a non-empty file (it is not an MCAP file, or no whole chunk reached the disk)."""
    damaged = Path(damaged)
    check_not_being_written(damaged)
    files = sorted(damaged.glob("*.mcap")) if damaged.is_dir() else [damaged]
    if not files:
        raise BagError(f"no MCAP file found in {damaged}")
    check_new_bag(Path(recovered))
    messages = list(stream_messages(damaged))
    size = sum(f.stat().st_size for f in files)
    if not messages and size > 0:
        raise BagError(
            f"nothing could be recovered from {damaged} ({size} bytes): not an MCAP file, or no whole chunk "
            "of messages reached the disk"
        )
    with BagRecorder(recovered, swarm_typestore()) as recorder:
        for topic, msgtype, timestamp, data in messages:
            recorder.write_cdr(topic, msgtype, timestamp, data)
        return recorder.count


def rewrite_bag(
    path: Path, keep: Callable[[str, str, int, bytes], bool], typestore: Typestore | None = None
) -> int:
    """Replace the bag at ``path`` (whole, or left by a killed writer) by a whole bag of the messages for
    which ``keep(topic, type, timestamp, data)`` is true; return how many were kept.

    The new bag is written aside (``.<name>.rewrite-*/<name>``) and swapped in with two renames, the old one
    kept as ``.<name>.old-*`` until the swap is done; :func:`finish_rewrites` completes or undoes a swap
    interrupted by a kill."""
    path = Path(path)
    if (path / "metadata.yaml").exists():
        messages = [(m.topic, m.msgtype, m.timestamp_ns, m.data) for m in read_bag(path, typestore)]
    else:
        messages = list(stream_messages(path))
    aside = Path(tempfile.mkdtemp(prefix=f".{path.name}.rewrite-", dir=path.parent))
    kept = 0
    with BagRecorder(aside / path.name, typestore) as recorder:
        for topic, msgtype, timestamp, data in messages:
            if keep(topic, msgtype, timestamp, data):
                recorder.write_cdr(topic, msgtype, timestamp, data)
        kept = recorder.count
    old = path.parent / f".{path.name}.old-{aside.name.rsplit('-', 1)[1]}"
    os.rename(path, old)
    os.rename(aside / path.name, path)
    shutil.rmtree(old)
    shutil.rmtree(aside)
    return kept


def finish_rewrites(folder: Path) -> None:
    """Complete or undo what :func:`rewrite_bag` calls killed half-way left in ``folder``: a bag moved aside
    whose replacement never arrived is put back; leftovers are removed."""
    for old in sorted(Path(folder).glob(".*.old-*")):
        name = old.name[1:].rsplit(".old-", 1)[0]
        if not (old.parent / name).exists():
            os.rename(old, old.parent / name)
        else:
            shutil.rmtree(old, ignore_errors=True)
    for aside in Path(folder).glob(".*.rewrite-*"):
        shutil.rmtree(aside, ignore_errors=True)
