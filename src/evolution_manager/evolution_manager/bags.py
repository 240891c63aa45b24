"""Recording to rosbag2 bags with MCAP storage, reading them back, and recovering a bag whose writer was
killed.

Bags are written with ``rosbags`` (pure Python): rosbag2 format version 9, MCAP storage, CDR serialisation,
and the message definitions of ``swarm_msgs`` embedded, so ``ros2 bag``, Foxglove and the ``mcap`` tools can
open them. Nothing here imports ``rclpy``: nodes hand the recorder the CDR bytes they received (``raw=True``
subscriptions), and the manager hands it message objects of the ``rosbags`` typestore.

A writer killed with SIGKILL leaves an MCAP file without its summary and no ``metadata.yaml``; ``recover_bag``
reads such a file as a stream and writes a whole bag holding every message of the chunks that were flushed.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from .errors import BagError

INTERFACE_PACKAGE = "swarm_msgs"


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


class BagRecorder:
    """Write messages to a new rosbag2 bag with MCAP storage.

    Use as a context manager; the bag is whole (index and ``metadata.yaml`` written) once the context exits,
    also when the body raised. To stop a recording on a signal, set a flag in the signal handler and leave the
    context normally: a process killed inside ``write`` loses only the unflushed tail (see ``recover_bag``).
    """

    def __init__(self, path: Path | str, typestore: Typestore | None = None) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise BagError(f"refusing to overwrite {self.path}: choose a new bag directory")
        self.typestore = typestore or swarm_typestore()
        self._writer: Writer | None = None
        self._connections: dict[str, Any] = {}
        self.count = 0

    def __enter__(self) -> BagRecorder:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        return self

    def __exit__(self, *exc_info: object) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None

    def write_cdr(self, topic: str, msgtype: str, timestamp_ns: int, data: bytes | memoryview) -> None:
        """Record one message given as CDR bytes (as an rclpy ``raw=True`` subscription delivers it)."""
        if self._writer is None:
            raise BagError("the recorder is not open: use it as a context manager")
        connection = self._connections.get(topic)
        if connection is None:
            connection = self._writer.add_connection(topic, msgtype, typestore=self.typestore)
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
        """A message object of type ``msgtype`` (e.g. ``swarm_msgs/msg/EvaluationResult``)."""
        return self.typestore.types[msgtype](**fields)


@dataclass(frozen=True)
class BagMessage:
    """One message read back from a bag."""

    topic: str
    msgtype: str
    timestamp_ns: int
    data: bytes
    message: Any


def read_bag(path: Path | str, typestore: Typestore | None = None) -> Iterator[BagMessage]:
    """Every message of a whole bag, in timestamp order, deserialised with ``typestore``.

    Raises ``BagError`` at once (not on the first iteration) when ``path`` holds no whole bag."""
    path = Path(path)
    check_bag(path)
    return _messages(path, typestore or swarm_typestore())


def check_bag(path: Path) -> None:
    """Raise ``BagError`` saying what is wrong when ``path`` is not a whole rosbag2 bag."""
    if not path.exists():
        raise BagError(f"no bag at {path}")
    if not (path / "metadata.yaml").exists():
        raise BagError(
            f"{path} is not a whole rosbag2 bag (no metadata.yaml): if its recorder was killed, run "
            f"`ws/run evolution_manager recover {path} NEW_BAG`"
        )


def _messages(path: Path, store: Typestore) -> Iterator[BagMessage]:
    with Reader(path) as reader:
        for connection, timestamp, data in reader.messages():
            message = store.deserialize_cdr(data, connection.msgtype)
            yield BagMessage(connection.topic, connection.msgtype, timestamp, bytes(data), message)


def recover_bag(damaged: Path | str, recovered: Path | str) -> int:
    """Write a whole bag at ``recovered`` from every message that reached the disk in the MCAP file(s) of a
    bag whose writer was killed; return the number of messages recovered."""
    from mcap.exceptions import McapError
    from mcap.records import Channel, Message, Schema
    from mcap.stream_reader import StreamReader

    damaged = Path(damaged)
    files = sorted(damaged.glob("*.mcap")) if damaged.is_dir() else [damaged]
    if not files:
        raise BagError(f"no MCAP file found in {damaged}")
    typestore = swarm_typestore()
    with BagRecorder(recovered, typestore) as recorder:
        for file in files:
            schemas: dict[int, str] = {}
            channels: dict[int, tuple[str, str]] = {}
            with file.open("rb") as stream:
                try:
                    for record in StreamReader(stream, emit_chunks=False).records:
                        if isinstance(record, Schema):
                            schemas[record.id] = record.name
                        elif isinstance(record, Channel):
                            channels[record.id] = (record.topic, schemas.get(record.schema_id, ""))
                        elif isinstance(record, Message) and record.channel_id in channels:
                            topic, msgtype = channels[record.channel_id]
                            recorder.write_cdr(topic, msgtype, record.log_time, record.data)
                except (McapError, EOFError, ValueError, OSError):
                    pass  # the truncated tail: everything before it is kept
        return recorder.count
