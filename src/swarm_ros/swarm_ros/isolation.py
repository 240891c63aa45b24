"""Give each ROS 2 graph its own DDS domain, so that graphs started side by side never see each other.

``reserved_domain()`` holds an exclusive lock on one of the domain ids 1-101 (safe on Linux) as long as the
context lasts; every process of this user on this machine that reserves through it gets a different id. Tests
use it to run in parallel (colcon runs packages at once); the launcher uses it for graphs started by a user
command. The lock files lie in a folder of the user's own (``swarm-bt-qd-ros-domains-<uid>`` under the
temporary folder, mode 0700; one that is another user's or open to others is refused) and are opened without
following links (``swarm_ros.safe_paths``).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from swarm_ros.safe_paths import open_no_follow, private_folder

FIRST_DOMAIN = 1
LAST_DOMAIN = 101
LOCK_DIR = Path(tempfile.gettempdir()) / f"swarm-bt-qd-ros-domains-{os.getuid()}"


@contextlib.contextmanager
def reserved_domain() -> Iterator[int]:
    """Reserve a ROS_DOMAIN_ID that no other reservation of this user on this machine holds; yield it. A
    lock folder or lock file that is unsafe (a link, another user's folder) raises
    ``swarm_ros.safe_paths.UnsafePathError``, an ``OSError`` whose message is one line."""
    folder = private_folder(LOCK_DIR)
    count = LAST_DOMAIN - FIRST_DOMAIN + 1
    start = os.getpid() % count  # spread concurrent callers over the range
    for offset in range(count):
        domain = FIRST_DOMAIN + (start + offset) % count
        handle = os.fdopen(open_no_follow(folder / f"{domain}.lock", os.O_WRONLY | os.O_CREAT, 0o600), "w")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.close()
            continue
        try:
            yield domain
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
            handle.close()
        return
    raise RuntimeError(f"every ROS domain id {FIRST_DOMAIN}-{LAST_DOMAIN} is reserved on this machine")


def domain_environment(domain: int) -> dict[str, str]:
    """A copy of this process's environment with ROS_DOMAIN_ID set, for starting nodes in that domain."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain)
    env.pop("ROS_LOCALHOST_ONLY", None)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return env


@dataclass(frozen=True)
class Workspace:
    """A ROS domain reserved for one test or command, and the environment to start the workspace's
    processes in it."""

    domain: int
    env: dict[str, str]

    def with_env(self, **extra: str) -> dict[str, str]:
        """The environment with ``extra`` variables set (e.g. ``PYTHONHASHSEED``)."""
        return {**self.env, **extra}


def workspace() -> Iterator[Workspace]:
    """A ROS domain of the caller's own (no other test or graph on the machine uses it) and the environment
    in which the commands and nodes it starts see the workspace and that domain, for as long as the generator
    is open: the tests' one fixture (``workspace = pytest.fixture(isolation.workspace)`` in a conftest)."""
    with reserved_domain() as domain:
        yield Workspace(domain, domain_environment(domain))
