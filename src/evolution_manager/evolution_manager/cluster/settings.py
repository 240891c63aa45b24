"""Where the work runs: ``--cluster local|dask://HOST:PORT|slurm`` and ``--cluster-config FILE``, checked.

Reading the options imports no Dask: a command that runs locally pays nothing for the cluster support. Every
problem is a :class:`ClusterError` whose message is one line naming the option, the value and what was
expected (the commands print it and exit with status 2).

The YAML file of ``--cluster slurm`` (every key optional; ``docs/cluster.md`` says what each one costs)::

    cores: 4                  # cores of each SLURM job: that many Dask worker processes, one thread each
    memory: 8GB               # memory of each job, shared by its worker processes (at least 0.5 GiB each)
    walltime: "04:00:00"      # each job's time limit, [D-]HH:MM:SS
    partition: compute        # the SLURM partition (sbatch -p); default: the cluster's default partition
    account: my-project       # the account charged (sbatch -A); default: yours
    jobs: 8                   # jobs kept running (a cancelled or expired job is replaced)
    container: apptainer exec --bind /scratch swarm-bt-qd.sif   # put before the worker's Python
    python: /workspace/ws/python   # the worker's Python (default: this one; in a container the image's)
    interface: ib0            # the network interface of the scheduler and workers (default: loopback, for
                              # workers on this machine; name one where they run on other nodes)
    log_directory: logs/dask  # the jobs' output files (default: sbatch's, in the working directory)
    dashboard: 127.0.0.1:8787 # where the scheduler's dashboard listens, HOST:PORT, or none (default loopback)
    tls_ca_file: ca.pem       # TLS between client, scheduler and workers: the CA, and the certificate and
    tls_cert: cert.pem        # key every party presents (all three, readable files; default: no TLS, see
    tls_key: key.pem          # docs/cluster.md on who may reach the scheduler)

With ``--cluster dask://HOST:PORT`` the file may give the three ``tls_*`` keys alone: the command then reaches
the scheduler over TLS (``tls://HOST:PORT``), presenting that certificate and checking the scheduler's against
that CA (a scheduler started with ``dask scheduler --tls-*``).

``--worker-wait SECONDS`` (default ``WORKER_WAIT``) bounds the wait for the first worker, on a ``dask://``
scheduler as under ``slurm``: the command says what it waits for, and gives up in one line.
"""

from __future__ import annotations

import argparse
import re
import shlex
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from urllib.parse import urlsplit

import yaml

from evolution_manager.errors import EvolutionError

KINDS = ("local", "dask", "slurm")

CHUNK = 25
"""Fewest evaluations of a single run sent as one Dask task (see :class:`~.evaluator.DaskEvaluator`)."""

IMAGE_PYTHON = "/workspace/ws/python"
"""The Python of the project's image (``docker/Dockerfile``): a worker's Python in a container by default."""

MIN_MEMORY_PER_WORKER = 512 * 2**20
"""Least memory a worker process gets (bytes): the interpreter, numba's kernels and a run's work."""

_UNITS = {"kb": 10**3, "mb": 10**6, "gb": 10**9, "tb": 10**12, "kib": 2**10, "mib": 2**20, "gib": 2**30}
_UNITS["tib"] = 2**40
_MEMORY = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([kmgt]i?b)\s*$", re.IGNORECASE)
_WALLTIME = re.compile(r"^(?:(\d+)-)?(\d{1,3}):([0-5]\d):([0-5]\d)$")
_NAME = re.compile(r"^[A-Za-z0-9_.@+-]+$")  # a partition, account or interface name: no spaces, no quotes
_HOST_PORT = re.compile(r"^(?P<host>[A-Za-z0-9_.-]+|\[[0-9A-Fa-f:.]+\]):(?P<port>\d{1,5})$")

LOOPBACK = "127.0.0.1"
"""Where the in-process scheduler of ``--cluster slurm`` listens when the settings name no interface."""

DASHBOARD = f"{LOOPBACK}:8787"
"""Where its dashboard listens by default."""

WORKER_WAIT = 300.0
"""Seconds a command waits for the first worker of a cluster before giving up (``--worker-wait``)."""


class ClusterError(EvolutionError):
    """A cluster setting that cannot be used: bad syntax, an unknown key, no scheduler, no SLURM."""


@dataclass(frozen=True)
class SlurmSettings:
    """The SLURM jobs that run the Dask workers (dask-jobqueue's ``SLURMCluster``); keys: the module's doc."""

    cores: int = 1
    memory: str = "2GB"
    walltime: str = "01:00:00"
    partition: str | None = None
    account: str | None = None
    jobs: int = 1
    container: str | None = None
    python: str | None = None
    interface: str | None = None
    log_directory: str | None = None
    dashboard: str | None = DASHBOARD
    """``HOST:PORT`` of the scheduler's dashboard, or None for none (``dashboard: none``)."""
    tls_ca_file: str | None = None
    tls_cert: str | None = None
    tls_key: str | None = None

    @property
    def tls(self) -> bool:
        """Whether client, scheduler and workers talk over TLS (the three files given)."""
        return self.tls_ca_file is not None

    def worker_python(self, default: str) -> str:
        """The command that starts the worker's Python in a job: the container's command, then the Python
        (``python`` when given, else the image's inside a container, else ``default``)."""
        python = self.python or (IMAGE_PYTHON if self.container else default)
        return f"{self.container} {python}" if self.container else python


TLS_KEYS = ("tls_ca_file", "tls_cert", "tls_key")
"""The settings of TLS, given all three or none: the CA, and the certificate and key this side presents."""


@dataclass(frozen=True)
class TlsFiles:
    """The PEM files of TLS with a ``dask://`` scheduler: the CA that signs the scheduler's certificate, and
    the certificate and key the command presents (absolute paths)."""

    tls_ca_file: str
    tls_cert: str
    tls_key: str


@dataclass(frozen=True)
class ClusterSettings:
    """Where the work runs: ``local`` (this machine's processes), ``dask`` (the scheduler at ``address``) or
    ``slurm`` (workers started as SLURM jobs, as ``slurm`` says). Results never depend on it."""

    kind: str = "local"
    address: str | None = None
    """``tcp://HOST:PORT`` of the scheduler, for ``dask`` (``tls://HOST:PORT`` with ``tls``)."""
    slurm: SlurmSettings | None = None
    tls: TlsFiles | None = None
    """For ``dask``: TLS with these files (``--cluster-config``), else plain TCP."""
    worker_wait: float = WORKER_WAIT
    """Seconds to wait for the first worker (``--worker-wait``); not recorded with the settings."""

    @property
    def is_local(self) -> bool:
        return self.kind == "local"

    def to_json(self) -> dict:
        """The settings as recorded beside the results (a session's record, not the run's configuration)."""
        slurm = asdict(self.slurm) if self.slurm else None
        recorded = {"kind": self.kind, "address": self.address, "slurm": slurm}
        if self.tls is not None:
            recorded["tls"] = asdict(self.tls)
        return recorded

    def describe_option(self) -> str:
        """The ``--cluster`` option of these settings, as given: ``dask://HOST:PORT`` or ``slurm``."""
        if self.kind == "dask":
            return re.sub(r"^(tcp|tls)://", "dask://", str(self.address))
        return self.kind

    def describe(self) -> str:
        """One line for the terminal: where the work goes."""
        if self.kind == "dask":
            return f"the Dask scheduler at {self.address}"
        if self.kind == "slurm" and self.slurm is not None:
            s = self.slurm
            return (
                f"{s.jobs} SLURM job(s) of {s.cores} core(s), {s.memory}, {s.walltime}"
                + (f" on partition {s.partition}" if s.partition else "")
                + (f" in '{s.container}'" if s.container else "")
            )
        return "this machine's processes"


def parse_cluster(option: str, config_file: Path | None = None) -> ClusterSettings:
    """The settings of ``--cluster OPTION`` and ``--cluster-config FILE``; raise :class:`ClusterError`."""
    if option == "slurm":
        slurm = read_slurm_settings(config_file) if config_file is not None else SlurmSettings()
        return ClusterSettings("slurm", slurm=slurm)
    if option != "local" and not option.startswith("dask://"):
        raise ClusterError(f"--cluster must be local, dask://HOST:PORT or slurm, got {option!r}")
    if option == "local":
        if config_file is not None:
            raise ClusterError(
                "--cluster-config applies to --cluster slurm or dask://HOST:PORT, not to --cluster local"
            )
        return ClusterSettings()
    address = scheduler_address(option)
    if config_file is None:
        return ClusterSettings("dask", address=address)
    tls = dask_tls(read_settings_file(config_file), f"--cluster-config {config_file}")
    return ClusterSettings("dask", address=address.replace("tcp://", "tls://", 1), tls=tls)


def dask_tls(data: dict, where: str) -> TlsFiles:
    """The TLS files of a ``dask://`` scheduler's settings: the three ``tls_*`` keys and nothing else (the
    other keys say how SLURM's jobs are made); raise :class:`ClusterError`."""
    for key in data:
        if key not in TLS_KEYS:
            raise ClusterError(
                f"{where}: {key!r} applies to --cluster slurm; with --cluster dask://HOST:PORT the file "
                f"gives {', '.join(TLS_KEYS)} only (TLS with a scheduler started with dask scheduler --tls-*)"
            )
    files = _tls_files(data, where)
    if files is None:
        raise ClusterError(
            f"{where}: expected tls_ca_file, tls_cert and tls_key (TLS with the scheduler), got no key"
        )
    return TlsFiles(**files)


def _tls_files(values: dict, where: str) -> dict[str, str] | None:
    """The ``tls_*`` files of ``values`` as absolute paths, all three readable, or None when none is given;
    raise :class:`ClusterError` for a missing one or one that is not a readable file."""
    tls = {key: values.get(key) for key in TLS_KEYS}
    if all(value is None for value in tls.values()):
        return None
    files = {}
    for key, value in tls.items():
        if value is None:
            raise ClusterError(
                f"{where}: {key} is missing; TLS takes tls_ca_file, tls_cert and tls_key together"
            )
        if not isinstance(value, str) or not Path(value).is_file():
            raise ClusterError(f"{where}: {key} must be a readable file (PEM), got {value!r}")
        files[key] = str(Path(value).absolute())
    return files


def scheduler_address(option: str) -> str:
    """``tcp://HOST:PORT`` of ``dask://HOST:PORT`` (an IPv6 host in brackets); raise :class:`ClusterError`."""
    expected = "expected dask://HOST:PORT, the address of a running Dask scheduler"
    try:
        parts = urlsplit(option)
        port = parts.port
    except ValueError as error:
        raise ClusterError(f"--cluster {option!r}: {error}; {expected}") from None
    if parts.scheme != "dask" or not parts.hostname or port is None or port == 0:
        raise ClusterError(f"--cluster {option!r}: {expected}")
    if parts.path not in ("", "/") or parts.query or parts.fragment or parts.username or parts.password:
        raise ClusterError(f"--cluster {option!r}: {expected}, with nothing after the port")
    host = f"[{parts.hostname}]" if ":" in parts.hostname else parts.hostname
    return f"tcp://{host}:{port}"


def read_slurm_settings(path: Path) -> SlurmSettings:
    """The settings of a ``--cluster-config`` YAML file, every key checked; raise :class:`ClusterError`."""
    return slurm_settings(read_settings_file(path), f"--cluster-config {path}")


def read_settings_file(path: Path) -> dict:
    """The mapping of a ``--cluster-config`` YAML file (UTF-8, each key once), its values not yet checked;
    raise :class:`ClusterError`."""
    where = f"--cluster-config {path}"
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as error:
        raise ClusterError(f"{where}: cannot read it ({error.strerror or error})") from None
    except UnicodeDecodeError as error:
        raise ClusterError(
            f"{where}: not UTF-8 text (byte {error.object[error.start]:#04x} at offset {error.start}); "
            "expected a YAML file of settings"
        ) from None
    try:
        data = _safe_load_unique(text)
    except _DuplicateKeyError as error:
        raise ClusterError(f"{where}: {error}") from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        at = f" at line {mark.line + 1}" if mark is not None else ""
        raise ClusterError(f"{where}: not valid YAML{at}") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ClusterError(f"{where}: expected a mapping of settings (key: value), got {type(data).__name__}")
    return data


class _DuplicateKeyError(ValueError):
    """A YAML mapping gives a key twice (YAML keeps the last without a word)."""


def _safe_load_unique(text: str) -> object:
    """``yaml.safe_load`` that refuses a key given twice in one mapping (:class:`_DuplicateKeyError`, naming
    the key and its line)."""

    class UniqueKeyLoader(yaml.SafeLoader):
        def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
            seen: set[object] = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                if key in seen:
                    raise _DuplicateKeyError(
                        f"the key {key!r} appears twice (line {key_node.start_mark.line + 1}); "
                        "expected each setting once"
                    )
                seen.add(key)
            return super().construct_mapping(node, deep=deep)

    loader = UniqueKeyLoader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


def slurm_settings(data: dict, where: str = "--cluster-config") -> SlurmSettings:
    """:class:`SlurmSettings` from a mapping, every key and value checked; raise :class:`ClusterError`."""
    known = [f.name for f in fields(SlurmSettings)]
    for key in data:
        if key not in known:
            raise ClusterError(f"{where}: unknown key {key!r}; the keys are {', '.join(known)}")
    values = dict(data)
    for key in ("cores", "jobs"):
        if key in values:
            values[key] = _count(values[key], f"{where}: {key}")
    if "memory" in values:
        values["memory"] = _memory(values["memory"], f"{where}: memory")
    if "walltime" in values:
        values["walltime"] = _walltime(values["walltime"], f"{where}: walltime")
    for key in ("partition", "account", "interface"):
        if values.get(key) is not None:
            values[key] = _name(values[key], f"{where}: {key}")
    for key in ("container", "python"):
        if values.get(key) is not None:
            values[key] = _command(values[key], f"{where}: {key}")
    if "dashboard" in values:
        values["dashboard"] = _dashboard(values["dashboard"], f"{where}: dashboard")
    values.update(_tls_files(values, where) or {})
    log_directory = values.get("log_directory")
    if log_directory is not None and (not isinstance(log_directory, str) or not log_directory.strip()):
        raise ClusterError(f"{where}: log_directory must be a directory path, got {log_directory!r}")
    settings = SlurmSettings(**values)
    per_worker = _bytes(settings.memory) / settings.cores
    if per_worker < MIN_MEMORY_PER_WORKER:
        raise ClusterError(
            f"{where}: memory {settings.memory} shared by {settings.cores} worker process(es) leaves "
            f"{per_worker / 2**20:.0f} MiB each; give at least 512 MiB per core"
        )
    return settings


def _dashboard(value: object, what: str) -> str | None:
    if value is None or (isinstance(value, str) and value.strip().lower() == "none"):
        return None
    match = _HOST_PORT.match(value) if isinstance(value, str) else None
    if match is None or int(match["port"]) > 65535:
        raise ClusterError(f"{what} must be HOST:PORT such as 127.0.0.1:8787, or none, got {value!r}")
    return str(value)


def _count(value: object, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ClusterError(f"{what} must be a positive integer, got {value!r}")
    return value


def _memory(value: object, what: str) -> str:
    if not isinstance(value, str) or not _MEMORY.match(value):
        raise ClusterError(f"{what} must be an amount with its unit such as 4GB or 3500MiB, got {value!r}")
    return value.strip()


def _bytes(memory: str) -> float:
    match = _MEMORY.match(memory)
    assert match is not None  # checked by _memory
    return float(match.group(1)) * _UNITS[match.group(2).lower()]


def _walltime(value: object, what: str) -> str:
    if not isinstance(value, str) or not _WALLTIME.match(value) or set(value) <= set("0:-"):
        raise ClusterError(
            f'{what} must be a time limit [D-]HH:MM:SS such as "04:00:00" (quoted in YAML), got {value!r}'
        )
    return value


def _name(value: object, what: str) -> str:
    if not isinstance(value, str) or not _NAME.match(value):
        raise ClusterError(f"{what} must be a name without spaces or quotes, got {value!r}")
    return value


def _command(value: object, what: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ClusterError(f"{what} must be a command (text), got {value!r}")
    try:
        shlex.split(value)
    except ValueError as error:
        raise ClusterError(f"{what}: cannot split {value!r} into words ({error})") from None
    return value.strip()


# The command line ---------------------------------------------------------------------------------------
def add_cluster_options(parser: argparse.ArgumentParser) -> None:
    """``--cluster`` and ``--cluster-config`` (for ``experiment``, ``evolve``, ``adapt-benchmark`` and the
    main job); :func:`settings_from_args` reads them."""
    parser.add_argument(
        "--cluster",
        default="local",
        metavar="local|dask://HOST:PORT|slurm",
        help="where the work runs: this machine's processes (default), the Dask scheduler at HOST:PORT, or "
        "Dask workers started as SLURM jobs (docs/cluster.md); results never depend on it",
    )
    parser.add_argument(
        "--cluster-config",
        type=Path,
        metavar="FILE",
        help="with --cluster slurm: a YAML file of cores, memory, walltime, partition, account, jobs, "
        "container, python, interface, log_directory, dashboard, tls_ca_file, tls_cert, tls_key; with "
        "--cluster dask://HOST:PORT: tls_ca_file, tls_cert and tls_key alone (docs/cluster.md)",
    )
    parser.add_argument(
        "--worker-wait",
        type=_worker_wait,
        metavar="SECONDS",
        help=f"with a cluster: how long to wait for its first worker before giving up (default "
        f"{WORKER_WAIT:g})",
    )


def settings_from_args(args: argparse.Namespace) -> ClusterSettings:
    """The :class:`ClusterSettings` of parsed ``--cluster``, ``--cluster-config`` and ``--worker-wait``."""
    settings = parse_cluster(args.cluster, args.cluster_config)
    wait = getattr(args, "worker_wait", None)
    if wait is None:
        return settings
    if settings.is_local:
        raise ClusterError("--worker-wait applies to --cluster dask://HOST:PORT or slurm, not to local")
    return replace(settings, worker_wait=wait)


def _worker_wait(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"expected a number of seconds > 0, got {text!r}")
    return value
