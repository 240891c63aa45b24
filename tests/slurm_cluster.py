"""A real one-node SLURM on this machine for the tests: MUNGE, slurmctld and slurmd, started and stopped here.

Debian's ``slurm-wlm`` and ``munge`` (installed by ``ws/setup``) run a cluster of one node, this machine, with
its own CPUs and memory (as ``slurmd -C`` reports them). Everything lives in one temporary directory: the key
and socket of MUNGE, ``slurm.conf``, the state and spool directories, the PID and log files. The daemons run
as root in the foreground (``-D``, ``-F``) on free ports, so several of these clusters (two test sessions at
once) do not meet; ``SLURM_CONF`` in :meth:`OneNodeSlurm.environment` points the client commands
(``sbatch``, ``srun``, ``squeue``, ``scancel``; dask-jobqueue calls them) at this one. Processes are
tracked with ``proctrack/linuxproc`` and tasks bound by ``task/none``: no cgroups, which a container lacks.

Stopping cancels every job, waits for the queue to empty, ends the three daemons by their PIDs and then any
``slurmstepd`` that outlived them (a step daemon detaches from slurmd on purpose, to survive a restart of it):
those are found by the marker variable that every daemon of this cluster, and so every step daemon it starts,
carries in its environment, and ended by PID. Nothing is left running.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
import signal
import socket
import subprocess
import time
from pathlib import Path

MARKER = "SWARM_TEST_SLURM"
"""The environment variable, set to the cluster's directory, that every process of one cluster carries."""

COMMANDS = ("munged", "slurmctld", "slurmd", "sbatch", "srun", "sinfo", "squeue", "scancel")


class SlurmError(RuntimeError):
    """The one-node SLURM could not be started; the message says why and where the logs are."""


def missing_commands() -> list[str]:
    """The commands of SLURM and MUNGE this machine lacks (installed by ws/setup: slurm-wlm, munge)."""
    return [name for name in COMMANDS if shutil.which(name) is None]


def free_port() -> int:
    """A TCP port nobody listens on now (the kernel's choice)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def node_line() -> str:
    """This machine as a SLURM node: CPUs, sockets, cores, threads and memory, from ``slurmd -C``."""
    out = subprocess.run(["slurmd", "-C"], capture_output=True, text=True, check=True, timeout=30).stdout
    line = next(line for line in out.splitlines() if line.startswith("NodeName="))
    fields = dict(item.split("=", 1) for item in line.split())
    fields.pop("NodeName")
    return " ".join(f"{key}={value}" for key, value in fields.items())


class OneNodeSlurm:
    """A one-node SLURM in ``directory``: ``start()`` it, use :meth:`environment`, ``stop()`` it (or use it
    as a context manager). The node is called ``node``, its only partition ``test``."""

    NODE = "node"
    PARTITION = "test"

    def __init__(self, directory: Path) -> None:
        self.dir = Path(directory).absolute()
        self.conf = self.dir / "slurm.conf"
        self.munge_socket = self.dir / "munge" / "munge.socket"
        self.processes: dict[str, subprocess.Popen] = {}

    # The cluster's files -------------------------------------------------------------------------------
    def _write_files(self) -> None:
        self.dir.mkdir(parents=True, exist_ok=True)
        self.dir.chmod(0o755)  # MUNGE wants every directory above its socket open to all for execute
        for name in ("munge", "state", "spool", "log", "run"):
            (self.dir / name).mkdir(exist_ok=True)
            (self.dir / name).chmod(0o755)
        key = self.dir / "munge" / "munge.key"
        key.write_bytes(secrets.token_bytes(1024))  # a secret for this cluster only, not a draw of any result
        key.chmod(0o400)
        self.conf.write_text(
            "\n".join(
                [
                    "ClusterName=swarmtest",
                    f"SlurmctldHost={socket.gethostname().split('.')[0]}(127.0.0.1)",  # its own name
                    f"SlurmctldPort={free_port()}",
                    f"SlurmdPort={free_port()}",
                    "SlurmUser=root",
                    "SlurmdUser=root",
                    "AuthType=auth/munge",
                    "CredType=cred/munge",
                    f"AuthInfo=socket={self.munge_socket}",
                    f"StateSaveLocation={self.dir / 'state'}",
                    f"SlurmdSpoolDir={self.dir / 'spool'}",
                    f"SlurmctldPidFile={self.dir / 'run' / 'slurmctld.pid'}",
                    f"SlurmdPidFile={self.dir / 'run' / 'slurmd.pid'}",
                    f"SlurmctldLogFile={self.dir / 'log' / 'slurmctld.log'}",
                    f"SlurmdLogFile={self.dir / 'log' / 'slurmd.log'}",
                    "ProctrackType=proctrack/linuxproc",
                    "TaskPlugin=task/none",
                    "JobAcctGatherType=jobacct_gather/none",
                    "AccountingStorageType=accounting_storage/none",
                    "JobCompType=jobcomp/none",
                    "MpiDefault=none",
                    "MailProg=/bin/true",
                    "SwitchType=switch/none",
                    "SchedulerType=sched/backfill",
                    "SelectType=select/cons_tres",
                    "SelectTypeParameters=CR_CPU_Memory",
                    "ReturnToService=2",
                    "SlurmctldTimeout=30",
                    "SlurmdTimeout=30",
                    "InactiveLimit=0",
                    "KillWait=5",
                    "MinJobAge=60",
                    "SlurmctldDebug=info",
                    "SlurmdDebug=info",
                    f"NodeName={self.NODE} NodeAddr=127.0.0.1 {node_line()} State=UNKNOWN",
                    f"PartitionName={self.PARTITION} Nodes={self.NODE} Default=YES MaxTime=INFINITE State=UP",
                    "",
                ]
            )
        )

    def environment(self) -> dict[str, str]:
        """This process's environment with ``SLURM_CONF`` pointing at this cluster (for the client commands
        and the jobs, which inherit it through sbatch)."""
        return {**os.environ, "SLURM_CONF": str(self.conf)}

    def _daemon_environment(self) -> dict[str, str]:
        return {**self.environment(), MARKER: str(self.dir)}

    # Starting and stopping ------------------------------------------------------------------------------
    def start(self, timeout: float = 60.0) -> OneNodeSlurm:
        """Start MUNGE, slurmctld and slurmd and wait until ``sinfo`` shows the node idle; raise
        :class:`SlurmError` (after stopping whatever started) when that does not happen in ``timeout``."""
        missing = missing_commands()
        if missing:
            raise SlurmError(
                f"SLURM or MUNGE is not installed (missing: {', '.join(missing)}); ws/setup installs them "
                "(apt-get install slurm-wlm munge)"
            )
        self._write_files()
        munge = self.dir / "munge"
        try:
            self._spawn(
                "munged",
                [
                    "munged",
                    "--foreground",
                    "--force",
                    f"--socket={self.munge_socket}",
                    f"--key-file={munge / 'munge.key'}",
                    f"--pid-file={munge / 'munged.pid'}",
                    f"--log-file={self.dir / 'log' / 'munged.log'}",
                    f"--seed-file={munge / 'munged.seed'}",
                ],
            )
            self._wait(lambda: self.munge_socket.exists(), timeout, "MUNGE's socket to appear")
            self._spawn("slurmctld", ["slurmctld", "-D", "-i", "-f", str(self.conf)])
            self._spawn("slurmd", ["slurmd", "-D", "-N", self.NODE, "-f", str(self.conf)])
            self._wait(self._node_idle, timeout, f"sinfo to show the node {self.NODE} idle")
        except BaseException:
            self.stop()
            raise
        return self

    def _spawn(self, name: str, command: list[str]) -> None:
        log = (self.dir / "log" / f"{name}.out").open("wb")
        self.processes[name] = subprocess.Popen(
            command, env=self._daemon_environment(), stdout=log, stderr=subprocess.STDOUT
        )
        log.close()

    def _wait(self, condition: object, timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for name, process in self.processes.items():
                if process.poll() is not None:
                    raise SlurmError(
                        f"{name} exited with status {process.returncode} while waiting for {what}; "
                        f"logs in {self.dir / 'log'}:\n{self.logs()}"
                    )
            if condition():  # type: ignore[operator]
                return
            time.sleep(0.2)
        raise SlurmError(f"no {what} within {timeout:.0f} s; logs in {self.dir / 'log'}:\n{self.logs()}")

    def _node_idle(self) -> bool:
        return self.node_state() == "idle"

    def node_state(self) -> str:
        """The node's state as ``sinfo`` prints it (``idle``, ``mix``, ``alloc``, ``down*``...; empty when
        the controller does not answer)."""
        result = self.run(["sinfo", "--noheader", "--nodes", self.NODE, "--format", "%T"], check=False)
        return result.stdout.strip() if result.returncode == 0 else ""

    def run(self, command: list[str], check: bool = True, timeout: float = 60) -> subprocess.CompletedProcess:
        """A client command (sbatch, srun, squeue ...) against this cluster."""
        return subprocess.run(
            command, env=self.environment(), capture_output=True, text=True, check=check, timeout=timeout
        )

    def jobs(self) -> dict[str, str]:
        """Every job in the queue with its state (``PENDING``, ``RUNNING`` ...)."""
        out = self.run(["squeue", "--noheader", "--format", "%i %T"]).stdout
        return dict(line.split() for line in out.splitlines() if line.strip())

    def stray_processes(self) -> list[int]:
        """PIDs of processes of this cluster (its daemons, their step daemons) still alive."""
        found = []
        needle = f"{MARKER}={self.dir}".encode()
        for entry in Path("/proc").iterdir():
            if not entry.name.isdigit():
                continue
            try:
                environment = (entry / "environ").read_bytes()
            except OSError:  # gone meanwhile, or not ours to read
                continue
            if needle in environment.split(b"\0"):
                found.append(int(entry.name))
        return found

    def stop(self, timeout: float = 30.0) -> None:
        """Cancel every job, stop the daemons by PID and end what outlived them; leaves no process."""
        if "slurmctld" in self.processes and self.processes["slurmctld"].poll() is None:
            self.run(["scancel", "--full", "--partition", self.PARTITION], check=False)
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                try:
                    if not self.jobs():
                        break
                except subprocess.SubprocessError:
                    break
                time.sleep(0.3)
        for name in ("slurmd", "slurmctld", "munged"):
            process = self.processes.get(name)
            if process is None:
                continue
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
                try:
                    process.wait(timeout=timeout)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()
        for _ in range(50):  # step daemons and job processes of this cluster that outlived slurmd
            strays = self.stray_processes()
            if not strays:
                break
            for pid in strays:
                with contextlib.suppress(ProcessLookupError):  # ended meanwhile
                    os.kill(pid, signal.SIGKILL)
            time.sleep(0.1)
        self.processes.clear()

    def logs(self, lines: int = 15) -> str:
        """The last lines of every log of this cluster (for error messages)."""
        parts = []
        for path in sorted((self.dir / "log").glob("*")):
            text = path.read_text(errors="replace").splitlines()[-lines:]
            parts.append(f"--- {path.name}\n" + "\n".join(text))
        return "\n".join(parts)

    def __enter__(self) -> OneNodeSlurm:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
