"""A Dask client for :class:`~.settings.ClusterSettings`: connected to a running scheduler, or to workers that
dask-jobqueue starts as SLURM jobs; checked before any work is sent.

``open_client`` is a context manager: it yields ``None`` for ``local`` (the caller keeps its own processes),
else a ``distributed.Client``, and closes what it opened (the SLURM jobs included) on the way out.

Under ``slurm`` a :class:`JobKeeper` keeps the number of jobs: a job that left SLURM's queue (cancelled, out
of walltime, its node failed) is replaced by a new one. dask-jobqueue does not do that by itself for jobs of
several worker processes, and a long experiment outlives any walltime.
"""

from __future__ import annotations

import asyncio
import getpass
import importlib.util
import logging
import shutil
import socket
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any
from urllib.parse import urlsplit

from evolution_manager.cluster.settings import LOOPBACK, ClusterError, ClusterSettings, SlurmSettings

if TYPE_CHECKING:
    from distributed import Client
    from distributed.security import Security

CONNECT_TIMEOUT = 10.0
"""Seconds to wait for a scheduler to answer (``dask://``)."""

SLURM_COMMANDS = ("sbatch", "squeue", "scancel")
"""What dask-jobqueue calls: SLURM is installed where these are on PATH."""

JOB_NAME = "swarm-bt-qd"
"""The name of the worker jobs in ``squeue``."""

LOST_JOB_CHECK = 5.0
"""Seconds between two counts of the SLURM jobs (a cancelled or expired one is then replaced)."""

ALLOWED_FAILURES = 10
"""Worker deaths a task may see before it counts as failed, where this process runs the scheduler (slurm):
a whole run may outlive several jobs' walltimes (Dask's default is 3)."""


def check_scheduler(address: str, timeout: float = CONNECT_TIMEOUT, security: Security | None = None) -> None:
    """Raise :class:`ClusterError` unless a Dask scheduler answers at ``address`` (``tcp://HOST:PORT``, or
    ``tls://HOST:PORT`` with ``security``) within ``timeout`` seconds: first a TCP connection, then Dask's
    ``identity`` request (a port that accepts but never speaks Dask would otherwise keep a client waiting for
    ever)."""
    parts = urlsplit(address)
    option = f"--cluster dask://{parts.netloc}"
    try:
        with socket.create_connection((parts.hostname, parts.port), timeout=timeout):
            pass
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise ClusterError(
            f"{option}: no Dask scheduler answers there ({reason}); start one (dask scheduler) or give its "
            "address"
        ) from None
    from distributed.comm import connect  # imported before the clock starts

    arguments = security.get_connection_args("client") if security is not None else {}
    try:
        identity = asyncio.run(asyncio.wait_for(_identity(connect, address, arguments), timeout))
    except (OSError, TimeoutError, ValueError, TypeError) as error:
        identity = {"error": str(error) or type(error).__name__}
    if not isinstance(identity, dict) or identity.get("type") != "Scheduler":
        if security is None:
            expected = (
                "a scheduler that speaks TLS needs tls_ca_file, tls_cert and tls_key in --cluster-config"
            )
        else:
            expected = "a Dask scheduler over TLS whose certificate the CA of tls_ca_file signed"
        raise ClusterError(f"{option}: something answers there, but not as a Dask scheduler ({expected})")


async def _identity(connect: Callable, address: str, arguments: dict[str, Any]) -> object:
    comm = await connect(address, **arguments)
    try:
        await comm.write({"op": "identity"})
        return await comm.read()
    finally:
        comm.abort()


def check_slurm() -> None:
    """Raise :class:`ClusterError` unless SLURM's commands are on PATH."""
    missing = [name for name in SLURM_COMMANDS if shutil.which(name) is None]
    if missing:
        raise ClusterError(
            f"--cluster slurm: SLURM is not installed here (no {', '.join(missing)} on PATH); run on a login "
            "node of a SLURM cluster, or use --cluster local or dask://HOST:PORT"
        )


def slurm_cluster_options(settings: SlurmSettings, python: str = sys.executable) -> dict[str, Any]:
    """The arguments of dask-jobqueue's ``SLURMCluster`` for ``settings``: one Dask worker process of one
    thread per core (the kernels run on one thread each), the container command before the worker's Python.

    The scheduler (in this process) and the workers listen on the interface the settings name, else on
    loopback only (workers on this machine); its dashboard where ``dashboard`` says (loopback by default);
    with ``tls_*`` files, every connection is TLS with those certificates (``distributed.security``)."""
    scheduler: dict[str, Any] = {"dashboard_address": settings.dashboard}
    options: dict[str, Any] = {
        "cores": settings.cores,
        "processes": settings.cores,
        "memory": settings.memory,
        "walltime": settings.walltime,
        "queue": settings.partition,
        "account": settings.account,
        "python": settings.worker_python(python),
        "interface": settings.interface,
        "log_directory": settings.log_directory,
        "job_name": JOB_NAME,
        "death_timeout": 120,
        "scheduler_options": scheduler,
    }
    if settings.interface is None:  # nothing named: nobody beyond this machine may connect
        scheduler["host"] = LOOPBACK
        options["worker_extra_args"] = ["--host", LOOPBACK]
    if settings.tls:
        options["security"] = cluster_security(settings)
    return options


def dask_security(settings: ClusterSettings) -> Security | None:
    """TLS for the client of a ``dask://`` scheduler, as its settings give it (None: plain TCP): the settings'
    certificate presented, the scheduler's checked against their CA, every connection encrypted."""
    if settings.tls is None:
        return None
    # Dask (about 0.3 s to import) loads only for a cluster
    from distributed.security import Security

    return Security(
        tls_ca_file=settings.tls.tls_ca_file,
        tls_client_cert=settings.tls.tls_cert,
        tls_client_key=settings.tls.tls_key,
        require_encryption=True,
    )


def cluster_security(settings: SlurmSettings) -> Security:
    """TLS for the client, the scheduler and the workers, each presenting the settings' certificate, every
    connection encrypted and checked against their CA."""
    # Dask (about 0.3 s to import) loads only for a cluster
    from distributed.security import Security

    return Security(
        tls_ca_file=settings.tls_ca_file,
        tls_client_cert=settings.tls_cert,
        tls_client_key=settings.tls_key,
        tls_scheduler_cert=settings.tls_cert,
        tls_scheduler_key=settings.tls_key,
        tls_worker_cert=settings.tls_cert,
        tls_worker_key=settings.tls_key,
        require_encryption=True,
    )


def check_sbatch(cluster: Any, timeout: float = 60.0) -> None:
    """Raise :class:`ClusterError` unless ``sbatch`` would accept the cluster's worker job: the job script is
    given to ``sbatch --test-only``, which asks SLURM's controller and submits nothing. A controller that
    does not answer, a partition or account that does not exist, or a broken ``sbatch`` is one line here,
    before anything is written, rather than a retry with a traceback every few seconds for ever."""
    try:
        done = subprocess.run(
            ["sbatch", "--test-only"],
            input=cluster.job_script(),
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        raise ClusterError(
            f"--cluster slurm: sbatch did not answer in {timeout:g} s: is SLURM's controller reachable?"
        ) from None
    except OSError as error:
        raise ClusterError(f"--cluster slurm: sbatch cannot be run ({error.strerror or error})") from None
    if done.returncode != 0:
        lines = [line.strip() for line in (done.stderr or done.stdout).splitlines() if line.strip()]
        said = lines[-1] if lines else f"exit status {done.returncode}"
        raise ClusterError(f"--cluster slurm: sbatch refuses the worker jobs: {said}")


def wait_for_workers(
    client: Client, settings: ClusterSettings, address: str, say: Callable[[str], None] | None
) -> None:
    """Wait up to ``settings.worker_wait`` seconds for the first worker to join the scheduler at ``address``,
    having said so; raise :class:`ClusterError` in one line when none came."""
    if client.scheduler_info().get("workers"):
        return
    wait = settings.worker_wait
    where = "SLURM's jobs to start their workers" if settings.kind == "slurm" else "a worker to join"
    if say is not None:
        say(f"cluster: waiting up to {wait:g} s for {where} (scheduler {address}; --worker-wait SECONDS)")
    try:
        client.wait_for_workers(1, timeout=wait)
    except TimeoutError:
        if settings.kind == "slurm":
            hint = (
                "their jobs may wait in SLURM's queue (squeue --me), or cannot reach the scheduler (name "
                "the network interface the nodes share: interface in --cluster-config)"
            )
        else:
            tls = " with the --tls-* options of its certificates" if settings.tls is not None else ""
            hint = f"start workers (dask worker {address}{tls}) or give a longer --worker-wait"
        raise ClusterError(
            f"--cluster {settings.describe_option()}: no worker joined the scheduler at {address} in "
            f"{wait:g} s; {hint}"
        ) from None


def _quiet(loop: Any, context: dict[str, Any]) -> None:
    """The exception handler of the client's event loop: Dask's own tasks that end with the client (its
    gathers, its reconnection) when a command is interrupted or loses its scheduler are dropped; the command
    has said why in one line. Anything else goes to asyncio's default handler."""
    # Dask (about 0.3 s to import) loads only for a cluster
    from distributed.client import AllExit
    from distributed.comm import CommClosedError

    error = context.get("exception")
    if isinstance(error, (AllExit, asyncio.CancelledError, CommClosedError)):
        return
    loop.default_exception_handler(context)


class _LostScheduler(logging.Filter):
    """Drops distributed's "Failed to reconnect to scheduler" line: the command says in one line that the
    scheduler was lost (``DaskEvaluator``, ``map_runs``) and how to continue."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith("Failed to reconnect to scheduler")


_LOST_SCHEDULER = _LostScheduler()


class _InterruptedSync(logging.Filter):
    """Drops tornado's report of distributed's own ``sync`` failing to cancel the call that Ctrl-C
    interrupted: when the interrupt comes before that call has begun, the cancel callback reads a variable
    not yet set (a ``NameError`` in ``distributed.utils``, logged on the client's event-loop thread at any
    moment after the interrupt). The command has said in one line that it was interrupted."""

    def filter(self, record: logging.LogRecord) -> bool:
        error = record.exc_info[1] if record.exc_info else None
        return not (isinstance(error, NameError) and "sync.<locals>.cancel" in record.getMessage())


_INTERRUPTED_SYNC = _InterruptedSync()


@contextmanager
def _silenced() -> Iterator[None]:
    """Log records up to ERROR dropped within the block (distributed's loggers set their own levels, so
    raising a parent's level would not do)."""
    previous = logging.root.manager.disable
    logging.disable(logging.ERROR)
    try:
        yield
    finally:
        logging.disable(previous)


def dashboard_link(client: Client, local_scheduler: bool) -> str | None:
    """The scheduler's dashboard address, or None when it has none (a scheduler in this process serves
    its dashboard only where bokeh is installed)."""
    services = client.scheduler_info().get("services", {})
    if "dashboard" not in services or (local_scheduler and importlib.util.find_spec("bokeh") is None):
        return None
    return client.dashboard_link


def queued_jobs() -> set[str] | None:
    """The ids of this user's jobs named :data:`JOB_NAME` in SLURM's queue (pending, running, completing);
    None when squeue does not answer."""
    try:
        out = subprocess.run(
            ["squeue", "--noheader", "--format=%i", f"--name={JOB_NAME}", f"--user={_user()}"],
            capture_output=True,
            text=True,
            timeout=60,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    if out.returncode != 0:
        return None
    return {line.strip() for line in out.stdout.splitlines() if line.strip()}


def _user() -> str:

    return getpass.getuser()


class JobKeeper(threading.Thread):
    """Keeps ``jobs`` SLURM jobs for ``cluster`` (a dask-jobqueue ``SLURMCluster``): every ``interval``
    seconds, a job that is no longer in SLURM's queue is dropped and a new one submitted. Its tasks were
    already sent elsewhere by the scheduler when its workers vanished. Stop with :meth:`stop`."""

    def __init__(self, cluster: Any, jobs: int, interval: float = LOST_JOB_CHECK) -> None:
        super().__init__(name="swarm-bt-qd-job-keeper", daemon=True)
        self.cluster = cluster
        self.jobs = jobs
        self.interval = interval
        self.replaced = 0
        """Jobs replaced so far."""
        self._stopping = threading.Event()

    def run(self) -> None:
        while not self._stopping.wait(self.interval):
            submitted = {name: job.job_id for name, job in list(self.cluster.workers.items()) if job.job_id}
            queued = queued_jobs()
            if queued is None:
                continue  # SLURM's controller is busy or restarting: look again later
            lost = [name for name, job_id in submitted.items() if job_id not in queued]
            missing = len(self.cluster.worker_spec) - len(self.cluster.workers)
            if lost or missing > 0:
                self.replaced += len(lost)
                self.cluster.loop.add_callback(self._replace, lost)

    def _replace(self, lost: list[str]) -> None:  # on the cluster's event loop
        for name in lost:
            self.cluster.workers.pop(name, None)
        self.cluster.scale(jobs=self.jobs)  # submits a job for every planned one without a job

    def stop(self) -> None:
        self._stopping.set()
        self.join()


@contextmanager
def open_client(
    settings: ClusterSettings, say: Callable[[str], None] | None = None, timeout: float = CONNECT_TIMEOUT
) -> Iterator[Client | None]:
    """A client for ``settings`` (None for ``local``), checked and closed at the end; ``say`` gets a line or
    two for the terminal (where the work goes, the dashboard). Raise :class:`ClusterError` when the scheduler
    does not answer or SLURM is missing."""
    if settings.kind == "local":
        yield None
        return
    if settings.kind == "dask":
        assert settings.address is not None  # set by parse_cluster
        check_scheduler(settings.address, timeout, dask_security(settings))
    else:
        check_slurm()
    # Dask (about 0.3 s to import) loads only for a cluster
    import dask
    from distributed import Client

    logging.getLogger("distributed").setLevel(logging.WARNING)  # its INFO lines are not for a terminal
    logging.getLogger("tornado.application").addFilter(_INTERRUPTED_SYNC)  # once: a filter is added once
    cluster = None
    keeper = None
    client = None
    with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES}):
        try:
            if settings.kind == "dask":
                client = Client(settings.address, timeout=timeout, security=dask_security(settings))
                address = str(settings.address)
            else:
                # dask-jobqueue only for --cluster slurm
                from dask_jobqueue import SLURMCluster

                assert settings.slurm is not None  # set by parse_cluster
                cluster = SLURMCluster(**slurm_cluster_options(settings.slurm))
                check_sbatch(cluster)  # before any job is submitted or anything written
                cluster.scale(jobs=settings.slurm.jobs)
                keeper = JobKeeper(cluster, settings.slurm.jobs)
                keeper.start()
                security = cluster_security(settings.slurm) if settings.slurm.tls else None
                client = Client(cluster, security=security)
                address = str(cluster.scheduler_address)
            loop = getattr(client.loop, "asyncio_loop", None)  # tornado's IOLoop over asyncio's
            if loop is not None:
                loop.set_exception_handler(_quiet)
            if say is not None:
                say(f"cluster: work goes to {settings.describe()}")
                link = dashboard_link(client, local_scheduler=cluster is not None)
                if link:
                    say(f"cluster: Dask dashboard at {link}")
            wait_for_workers(client, settings, address, say)
        except BaseException as error:  # ClusterError, Ctrl-C while waiting: close what was opened, quietly
            _close(client, cluster, keeper)
            if not isinstance(error, (OSError, TimeoutError)) or isinstance(error, ClusterError):
                raise
            if settings.kind == "dask":
                where = settings.describe_option()
                raise ClusterError(f"--cluster {where}: the scheduler does not answer ({error})") from None
            raise ClusterError(f"--cluster slurm: the jobs' Dask scheduler did not start ({error})") from None
        logging.getLogger("distributed.client").addFilter(_LOST_SCHEDULER)
        try:
            yield client
        finally:
            _close(client, cluster, keeper)
            logging.getLogger("distributed.client").removeFilter(_LOST_SCHEDULER)


def _close(client: Client | None, cluster: Any, keeper: JobKeeper | None) -> None:
    """Close what :func:`open_client` opened, without Dask's log lines and tracebacks of a client closed
    mid-work or after losing its scheduler (the command has said what happened in one line)."""
    with _silenced():
        if keeper is not None:
            keeper.stop()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
