"""Start and stop node graphs as separate processes: the launcher behind ``trial``, the manager and the tests.

A full ROS 2 install would use ``ros2 launch`` (see the launch files in ``launch/``); the PyPI wheels have no
``launch``, so this module starts the installed executables itself, each in its own process, all in one ROS
domain, and stops them with SIGINT, then SIGKILL for any that does not stop in time. Nothing here imports
``rclpy``.
"""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import IO

from ament_index_python.packages import PackageNotFoundError, get_package_prefix

from bt_controller.nodes.isolation import domain_environment
from evolution_manager.errors import GraphError


def executable(package: str, name: str) -> Path:
    """The installed executable ``name`` of ``package`` (where ``ros2 run`` finds it)."""
    try:
        prefix = Path(get_package_prefix(package))
    except PackageNotFoundError:
        raise GraphError(f"package {package} is not installed: source the workspace (ws/env.sh)") from None
    path = prefix / "lib" / package / name
    if not os.access(path, os.X_OK):
        raise GraphError(f"package {package} has no executable {name} (looked for {path})")
    return path


class Graph:
    """A set of node processes in one ROS domain; a context manager that stops them all on exit."""

    def __init__(self, domain: int, log_dir: Path | None = None) -> None:
        self.domain = domain
        self.log_dir = log_dir
        self.processes: dict[str, subprocess.Popen] = {}
        self._logs: list[IO[str]] = []

    def __enter__(self) -> Graph:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    def start(
        self,
        name: str,
        package: str,
        executable_name: str,
        *,
        namespace: str = "",
        node_name: str = "",
        parameters: dict[str, object] | None = None,
        arguments: Sequence[str] = (),
    ) -> subprocess.Popen:
        """Start one node process, known in this graph as ``name``."""
        if name in self.processes:
            raise GraphError(f"a process named {name} is already running")
        command = [str(executable(package, executable_name)), *arguments, "--ros-args"]
        if namespace:
            command += ["-r", f"__ns:={namespace}"]
        if node_name:
            command += ["-r", f"__node:={node_name}"]
        for key, value in (parameters or {}).items():
            command += ["-p", f"{key}:={value}"]
        output: IO[str] | int = subprocess.DEVNULL
        if self.log_dir is not None:
            self.log_dir.mkdir(parents=True, exist_ok=True)
            output = (self.log_dir / f"{name}.log").open("w")
            self._logs.append(output)
        process = subprocess.Popen(
            command,
            env=domain_environment(self.domain),
            stdout=output,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
        )
        self.processes[name] = process
        return process

    def check(self) -> None:
        """Raise ``GraphError`` naming every process that has exited."""
        dead = [
            f"{name} (exit code {p.returncode})" for name, p in self.processes.items() if p.poll() is not None
        ]
        if dead:
            where = f"; see the logs in {self.log_dir}" if self.log_dir else ""
            raise GraphError(f"node process(es) exited: {', '.join(dead)}{where}")

    def kill(self, name: str) -> None:
        """Kill one process with SIGKILL (for fault-injection tests) and forget it."""
        process = self.processes.pop(name)
        process.send_signal(signal.SIGKILL)
        process.wait()

    def stop(self, timeout: float = 10.0) -> None:
        """Stop every process: SIGINT, then SIGKILL for those still running after ``timeout`` seconds."""
        for process in self.processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for process in self.processes.values():
            try:
                process.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        self.processes.clear()
        for log in self._logs:
            log.close()
        self._logs.clear()


def start_trial_graph(graph: Graph, robots: int = 9) -> None:
    """Start the simulator and one footbot controller per robot, each in its own process."""
    graph.start("simulator", "swarm_sim", "simulator", parameters={"robots": robots})
    for i in range(robots):
        graph.start(
            f"footbot_{i}",
            "bt_controller",
            "footbot_controller",
            namespace=f"/footbot_{i}",
            parameters={"robot": i},
        )
