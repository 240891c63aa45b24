"""The workspace's one rule for writing files in places other people can touch (shared run folders,
tarballs, ``git clone`` of ``experiments/``, the machine's temporary folder):

- never write through a symbolic link: a link planted where a command writes (a lock file, a log, a result
  folder, an output) is refused in one line, never followed (:func:`open_no_follow`, :func:`refuse_links`,
  :func:`refuse_links_within`);
- a command's output that exists is refused unless the command was given ``--force`` (:func:`check_output`);
- a folder of lock files is this user's own, mode 0700 (:func:`private_folder`).

Every refusal is an ``OSError`` (so the commands' existing handling of unwritable places reports it in one
line) whose ``str`` is one sentence naming the path and what to do. Nothing here imports ``rclpy``.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path


class UnsafePathError(OSError):
    """A path was refused: a symbolic link where a file or folder is written, an output that exists, a
    folder that is not the user's own. ``str(error)`` and ``error.strerror`` are the one-line reason."""

    def __init__(self, code: int, reason: str, path: Path | str) -> None:
        super().__init__(code, reason, str(path))

    def __str__(self) -> str:
        return str(self.strerror)


def _link_error(path: Path | str) -> UnsafePathError:
    try:
        target = f" (to {os.readlink(path)})"
    except OSError:
        target = ""
    return UnsafePathError(
        errno.ELOOP,
        f"{path} is a symbolic link{target}: refusing to write through it; remove the link",
        path,
    )


def open_no_follow(path: Path | str, flags: int, mode: int = 0o666) -> int:
    """``os.open(path, flags | O_NOFOLLOW | O_CLOEXEC, mode)``: a file descriptor, never of a link's
    target. A symbolic link at ``path`` raises :class:`UnsafePathError`; other errors are the system's."""
    try:
        return os.open(path, flags | os.O_NOFOLLOW | os.O_CLOEXEC, mode)
    except OSError as error:
        if error.errno == errno.ELOOP or (error.errno == errno.EEXIST and os.path.islink(path)):
            raise _link_error(path) from None
        raise


def refuse_links(path: Path | str, root: Path | str | None = None) -> None:
    """Raise :class:`UnsafePathError` if ``path`` is a symbolic link, or (with ``root``, a folder ``path``
    lies in) any folder between ``root`` and ``path``: what a command writes inside a run folder stays in
    it. ``root`` itself, and the folders above it, may be links (the user's own layout)."""
    path = Path(path)
    parts = [path]
    if root is not None:
        root = Path(root)
        try:
            relative = path.relative_to(root)
        except ValueError:
            relative = None
        if relative is not None:
            parts = [root.joinpath(*relative.parts[: k + 1]) for k in range(len(relative.parts))]
    for part in parts:
        if part.is_symlink():
            raise _link_error(part)


def refuse_links_within(folder: Path | str) -> None:
    """Raise :class:`UnsafePathError` for the first symbolic link (in name order, depth first) at any depth
    in ``folder``: for a folder that holds nothing but what a command made there (an experiment's), where a
    planted link would send what the command writes elsewhere. ``folder`` itself may be a link (the user's
    own layout), or missing; links are never followed."""

    def walk(path: str) -> None:
        with os.scandir(path) as entries:
            for entry in sorted(entries, key=lambda e: e.name):
                if entry.is_symlink():
                    raise _link_error(entry.path)
                if entry.is_dir(follow_symlinks=False):
                    walk(entry.path)

    with contextlib.suppress(FileNotFoundError, NotADirectoryError):
        walk(os.fspath(folder))


def make_folder(path: Path | str, root: Path | str | None = None) -> Path:
    """Create the folder ``path`` (and its parents) unless it exists; refuse a symbolic link at it, or
    between ``root`` and it (:func:`refuse_links`). Returns ``path``."""
    path = Path(path)
    refuse_links(path, root)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise UnsafePathError(errno.EEXIST, f"{path} is a file, not a folder", path) from None
    except NotADirectoryError:
        raise UnsafePathError(errno.ENOTDIR, f"{path}: {not_a_folder(path)}", path) from None
    refuse_links(path, root)  # planted meanwhile
    return path


def not_a_folder(path: Path | str) -> str:
    """Why ``path`` cannot be made (``ENOTDIR``): the part of it that is a file, not a folder."""
    for parent in reversed(Path(path).parents):
        if parent.exists() and not parent.is_dir():
            return f"{parent} is a file, not a folder"
    return "a part of the path is a file, not a folder"


def describe(path: Path | str, error: OSError) -> str:
    """One line for ``error``, raised writing ``path``: a refusal's own message, "... is a file, not a
    folder" for a place under a file (``ENOTDIR``, or the ``EEXIST`` of making a folder where a file is),
    else the path and the system's reason."""
    if isinstance(error, UnsafePathError):
        return str(error)
    if error.errno in (errno.ENOTDIR, errno.EEXIST):
        for parent in [Path(path), *Path(path).parents]:
            if parent.exists() and not parent.is_dir():
                return f"{path}: {parent} is a file, not a folder"
    return f"{path}: {error.strerror or error}"


def check_output(path: Path | str, force: bool = False, option: str = "--out") -> Path:
    """The rule for a command's output file: refuse (:class:`UnsafePathError`, one line naming ``option``)
    a symbolic link, even with ``force``; a folder; a file that exists unless ``force``; a place under a
    file. Returns ``path``. Write it with :func:`replace_file` or through :func:`open_no_follow`."""
    path = Path(path)
    if path.is_symlink():
        raise UnsafePathError(errno.ELOOP, f"{option} {_link_error(path)}", path)
    if path.is_dir():
        raise UnsafePathError(
            errno.EISDIR, f"{option} {path} is a folder: name the file to write (e.g. {path / 'NAME'})", path
        )
    if path.exists() and not force:
        raise UnsafePathError(
            errno.EEXIST,
            f"{option} {path} already exists: add --force to overwrite it, or name a new file",
            path,
        )
    _refuse_a_place_under_a_file(path, option)
    return path


def check_folder(path: Path | str, option: str = "--out") -> Path:
    """The rule for a folder a command writes in, which may exist (node logs): refuse
    (:class:`UnsafePathError`, one line naming ``option``) a symbolic link at it, a file there, a place
    under a file. Returns ``path``; create it with :func:`make_folder`."""
    path = Path(path)
    if path.is_symlink():
        raise UnsafePathError(errno.ELOOP, f"{option} {_link_error(path)}", path)
    if path.exists() and not path.is_dir():
        raise UnsafePathError(errno.ENOTDIR, f"{option} {path} is a file, not a folder", path)
    _refuse_a_place_under_a_file(path, option)
    return path


def _refuse_a_place_under_a_file(path: Path, option: str) -> None:
    """Refuse ``path`` when its nearest existing parent is a file, not a folder."""
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise UnsafePathError(
                    errno.ENOTDIR, f"{option} {path}: {parent} is a file, not a folder", path
                )
            return


def replace_file(path: Path | str, write: Callable[[Path], object]) -> Path:
    """Write ``path`` whole: ``write(temporary)`` (a callable taking a ``Path``, e.g. an image's ``save``)
    writes a new file beside it, which is then renamed over ``path``; a link at ``path`` is refused
    (:class:`UnsafePathError`), and a failed write leaves ``path`` as it was. Returns ``path``."""
    path = Path(path)
    refuse_links(path)
    descriptor, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(descriptor)
    temporary = Path(name)
    try:
        write(temporary)
        mask = os.umask(0o022)
        os.umask(mask)
        os.chmod(temporary, 0o666 & ~mask)  # mkstemp makes 0600; outputs are for people to open
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return path


def private_folder(path: Path | str) -> Path:
    """The folder ``path`` for this user's lock files: created with mode 0700 if missing; refused
    (:class:`UnsafePathError`, one line) if it is a link, not a folder, another user's, or open to others
    (another user could plant links in it, or take every lock)."""
    path = Path(path)
    with contextlib.suppress(FileExistsError):
        os.mkdir(path, 0o700)
    info = os.lstat(path)
    if stat.S_ISLNK(info.st_mode) or not stat.S_ISDIR(info.st_mode):
        raise UnsafePathError(
            errno.ENOTDIR, f"the lock folder {path} is not a folder (a link or a file): remove it", path
        )
    if info.st_uid != os.getuid():
        raise UnsafePathError(
            errno.EPERM,
            f"the lock folder {path} belongs to user id {info.st_uid}, not to you ({os.getuid()}): "
            "set TMPDIR to a folder of your own, or have it removed",
            path,
        )
    if info.st_mode & 0o077:
        raise UnsafePathError(
            errno.EPERM,
            f"the lock folder {path} has mode {stat.S_IMODE(info.st_mode):04o}, expected 0700 (only you): "
            f"chmod 700 {path}",
            path,
        )
    return path
