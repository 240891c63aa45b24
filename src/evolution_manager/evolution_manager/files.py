"""Small file helpers: atomic writes, strict JSON, append-only CSV logs that can be cut back on resume."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import math
import os
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from bt_controller.validate import strict_json
from evolution_manager.errors import RunDirectoryError, WriteError
from swarm_ros.safe_paths import open_no_follow, refuse_links


@contextlib.contextmanager
def writing(path: Path) -> Iterator[None]:
    """Turn an ``OSError`` while writing ``path`` (a full disk, a read-only folder) into a ``WriteError``
    that names the file."""
    try:
        yield
    except WriteError:
        raise
    except OSError as error:
        raise WriteError.of(path, error) from error


_APPEND = os.O_WRONLY | os.O_APPEND | os.O_CREAT


def printable(path: object) -> str:
    """``path`` (or any text) as text every stream and file can take: the bytes of a name that are not UTF-8
    (Python keeps them as surrogates, which a strict stream refuses with a traceback) shown as ``\\xNN``."""
    return str(path).encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def write_atomic(path: Path, data: str | bytes) -> None:
    """Write ``data`` to ``path`` so that a reader (or a killed writer) sees the old file or the new one,
    never a mixture: a temporary file in the same folder, flushed to disk, then renamed over ``path``. A
    failed write (``WriteError``, naming the file) leaves the old file as it was; so does a symbolic link at
    ``path`` (planted in a shared run folder), refused (``swarm_ros.safe_paths``). Text is written as UTF-8;
    the bytes of a file name that are not UTF-8 (which Python keeps as surrogates), e.g. a run folder's name
    quoted in a report, are written as ``\\xNN``."""
    path = Path(path)
    raw = printable(data).encode() if isinstance(data, str) else data
    with writing(path):
        refuse_links(path)
        _write_atomic(path, raw)


def _write_atomic(path: Path, raw: bytes) -> None:
    descriptor, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(descriptor, 0o666 & ~_umask())  # mkstemp makes 0600; results are for people to open
        with os.fdopen(descriptor, "wb") as handle:
            handle.write(raw)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def dumps(data: object, indent: int | None = 1) -> str:
    """Strict JSON (no NaN or infinity), keys in the order given, with a final newline; ``indent=None``
    writes one compact line (much faster, for checkpoints)."""
    return json.dumps(data, indent=indent, allow_nan=False) + "\n"


def write_json(path: Path, data: object, indent: int | None = 1) -> None:
    """Write ``data`` as strict JSON, atomically."""
    write_atomic(path, dumps(data, indent))


def read_json(path: Path) -> object:
    """Read a JSON file strictly (``bt_controller.validate.strict_json``: no NaN or infinities, no key given
    twice, which JSON would let the last win without a word), saying which file is damaged when it cannot be
    read."""
    try:
        return strict_json(Path(path).read_text())
    except FileNotFoundError as error:
        raise RunDirectoryError(f"{path} does not exist") from error
    except (OSError, ValueError) as error:
        raise RunDirectoryError(f"{path} is not a readable JSON file: {error}") from error


def read_json_object(path: Path) -> dict[str, Any]:
    """``read_json`` of a file whose top level must be a JSON object; say so, naming the file, if not."""
    data = read_json(path)
    if not isinstance(data, dict):
        raise RunDirectoryError(f"{path} is not a JSON object (it holds a {type(data).__name__})")
    return data


def number(value: float | None) -> str:
    """A float as CSV text that reads back to the same float (empty for None)."""
    if value is None:
        return ""
    if not math.isfinite(value):
        raise ValueError(f"refusing to write the non-finite number {value}")
    return repr(float(value))


class CsvLog:
    """An append-only CSV file whose length after each batch is recorded in the checkpoint, so that a
    resumed run cuts it back to the last checkpoint and appends exactly what an uninterrupted run would."""

    def __init__(self, path: Path, header: Sequence[str]) -> None:
        self.path = Path(path)
        self.header = list(header)

    def create(self) -> int:
        """Start the file with its header; return its length in bytes."""
        write_atomic(self.path, self._rows([self.header]))
        return self.path.stat().st_size

    def append(self, rows: Sequence[Sequence[str]]) -> int:
        """Append rows; return the new length in bytes. A failed write (``WriteError``) may leave part of a
        row at the end: a resume cuts the file back to its checkpoint. A symbolic link in place of the file
        is refused, never appended to."""
        with writing(self.path), os.fdopen(open_no_follow(self.path, _APPEND), "ab") as handle:
            handle.write(self._rows(rows).encode())
            handle.flush()
            return handle.tell()

    def size(self) -> int:
        """The file's length in bytes (-1 when it is missing)."""
        return self.path.stat().st_size if self.path.exists() else -1

    def cut(self, size: int) -> None:
        """Cut the file back to ``size`` bytes (the length recorded in a checkpoint)."""
        actual = self.size()
        if not 0 <= size <= actual:
            raise RunDirectoryError(
                f"{self.path} ({actual} bytes) cannot be cut back to the {size} bytes its checkpoint says"
            )
        with writing(self.path), os.fdopen(open_no_follow(self.path, os.O_RDWR), "r+b") as handle:
            handle.truncate(size)

    def read(self) -> list[dict[str, str]]:
        """All rows as dictionaries."""
        with open(self.path, newline="") as handle:
            return list(csv.DictReader(handle))

    @staticmethod
    def _rows(rows: Sequence[Sequence[str]]) -> str:
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerows(rows)
        return buffer.getvalue()
