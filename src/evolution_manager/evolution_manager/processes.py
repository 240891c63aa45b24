"""Process hygiene shared by every command that writes files or starts processes: exclusive locks, children
that die with their parent, and signals that end a command cleanly. Nothing here imports ``rclpy``.

- :func:`exclusive_lock` holds an ``flock`` on a lock file for the life of the process (or until released);
  a second process asking for it gets :class:`LockHeldError`, whose message names the holder's PID.
- :func:`die_with_parent` is a ``preexec_fn`` for ``subprocess.Popen``: the child gets SIGKILL when its parent
  dies, whatever killed the parent (``PR_SET_PDEATHSIG``), so no simulator, controller or evaluator is left
  running, adopted by PID 1, after ``kill -9`` of the command that started it.
- :func:`signals_as_interrupts` turns SIGTERM (and SIGINT) into :class:`Interrupted`, so a command unwinds
  through its ``finally`` blocks (stopping its children, closing its bags) and exits 128 + the signal number.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import hashlib
import os
import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path
from types import FrameType
from typing import IO

from evolution_manager.errors import Interrupted, LockHeldError
from swarm_ros.safe_paths import open_no_follow, private_folder

_PR_SET_PDEATHSIG = 1
_libc = ctypes.CDLL(None, use_errno=True)  # loaded before any fork: preexec_fn only calls into it


def exit_status(interruption: BaseException) -> int:
    """128 + the signal number of an interruption (a plain ``KeyboardInterrupt`` is SIGINT: 130)."""
    return interruption.exit_status if isinstance(interruption, Interrupted) else 128 + signal.SIGINT


# Locks ---------------------------------------------------------------------------------------------------
class Lock:
    """An exclusive lock held through an open file; released by :meth:`release` or when the process ends."""

    def __init__(self, path: Path, handle: IO[str]) -> None:
        self.path = path
        self._handle: IO[str] | None = handle

    def release(self) -> None:
        if self._handle is not None:
            fcntl.flock(self._handle, fcntl.LOCK_UN)
            self._handle.close()
            self._handle = None
            if _held.get(_key(self.path)) is self:
                del _held[_key(self.path)]

    def moved(self, path: Path) -> None:
        """The lock file was renamed (with its directory) to ``path``."""
        if _held.get(_key(self.path)) is self:
            del _held[_key(self.path)]
        self.path = Path(path)
        if self._handle is not None:
            _held[_key(self.path)] = self

    @property
    def held(self) -> bool:
        return self._handle is not None


_held: dict[str, Lock] = {}  # the locks this process holds, by real path


def _key(path: Path) -> str:
    return os.path.realpath(path)


def exclusive_lock(path: Path, what: str) -> Lock:
    """Take the exclusive lock of ``path`` (created if missing, mode 0600, never deleted: deleting a lock
    file races with a process opening it); write our PID into it. A symbolic link at ``path`` (planted in a
    shared run folder) is refused, never followed: ``swarm_ros.safe_paths.UnsafePathError``, an ``OSError``
    whose message is one line. ``what`` names the locked thing in the error, e.g.
    ``"the run directory runs/qd"``. Within one process a lock taken again is handed over to the new taker
    (the lock keeps other processes out)."""
    path = Path(path)
    previous = _held.get(_key(path))
    if previous is not None:
        previous.release()
    handle = os.fdopen(open_no_follow(path, os.O_RDWR | os.O_CREAT, 0o600), "r+")  # never a link's target
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as error:
        handle.close()
        if error.errno not in (errno.EAGAIN, errno.EACCES):
            raise
        holder = lock_holder(path)
        who = f"process {holder}" if holder else "another process"
        raise LockHeldError(
            f"{what} is in use by {who} (lock {path}): wait for it to end, or stop it"
        ) from None
    handle.seek(0)
    handle.truncate()
    handle.write(f"{os.getpid()}\n")
    handle.flush()
    lock = Lock(path, handle)
    _held[_key(path)] = lock
    return lock


def lock_path_for(thing: Path, kind: str) -> Path:
    """A lock file for ``thing`` kept outside it, in a folder of this user's under the machine's temporary
    folder, named by ``thing``'s full path: for things that must hold nothing but their own files."""
    folder = private_folder(Path(tempfile.gettempdir()) / f"swarm-bt-qd-locks-{os.getuid()}")
    digest = hashlib.sha256(os.fsencode(thing.resolve())).hexdigest()[:32]  # a name's bytes, UTF-8 or not
    return folder / f"{kind}-{digest}.lock"


def lock_holder(path: Path) -> int | None:
    """The PID written in the lock file ``path``, or None."""
    with contextlib.suppress(OSError, ValueError):
        return int(Path(path).read_text().split()[0])
    return None


def is_locked(path: Path) -> bool:
    """Whether some process holds the lock of ``path`` now (a missing file is not locked)."""
    try:
        handle = Path(path).open("r")  # noqa: SIM115 (closed below)
    except OSError:
        return False
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            return True
        fcntl.flock(handle, fcntl.LOCK_UN)
        return False


# Children ------------------------------------------------------------------------------------------------
def die_with_parent() -> None:
    """``preexec_fn``: ask the kernel to SIGKILL this child when the parent dies (and do it now if the parent
    died between ``fork`` and here). Linux only; elsewhere a no-op."""
    parent = os.getppid()
    if _libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
        return
    if os.getppid() != parent or parent == 1:
        os.kill(os.getpid(), signal.SIGKILL)


# Signals -------------------------------------------------------------------------------------------------
def _raise_interrupted(signum: int, frame: FrameType | None) -> None:
    raise Interrupted(signum)


@contextlib.contextmanager
def signals_as_interrupts(*signums: int) -> Iterator[None]:
    """While the context lasts, SIGINT and SIGTERM (or ``signums``) raise :class:`Interrupted` in the main
    thread; the previous handlers come back after."""
    signums = signums or (signal.SIGINT, signal.SIGTERM)
    previous = {s: signal.signal(s, _raise_interrupted) for s in signums}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
