"""A cluster that cannot work says so in one line, and a safe one by default (issue 41, items 3 and 4, and
the Dask security it asks for), with real Dask schedulers and workers (processes) and the real ``sbatch``:

- ``--cluster slurm`` where ``sbatch`` fails (no controller; a broken one): one line, before anything is
  written (it hung for ever, a traceback per retry, after creating the run folder);
- a Dask scheduler without workers: the command says what it waits for, gives up after ``--worker-wait``
  seconds in one line; Ctrl-C then, or mid-run, prints the "interrupted" line only (no ``AllExit``); a
  scheduler that dies mid-run is one line (no ``CancelledError`` tracebacks);
- the in-process scheduler of ``--cluster slurm`` listens on loopback unless the settings name an interface,
  its dashboard on loopback, and over TLS when the settings give certificates."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from distributed import Client

from evolution_manager.cluster.client import cluster_security, slurm_cluster_options
from evolution_manager.cluster.settings import ClusterError, SlurmSettings, parse_cluster

EVOLVE = ["-c", "from evolution_manager.studies.evolve import main; main()"]
RUN = ["--algorithm", "qd", "--objective", "food", "--no-progress", "--no-figures"]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def evolve(out: Path, *extra: str, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, *EVOLVE, *RUN, "--out", str(out), *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def no_traceback(err: str) -> None:
    for word in ("Traceback", "AllExit", "CancelledError", "ERROR", "never retrieved"):
        assert word not in err, err


def errors(err: str) -> list[str]:
    """The lines of stderr but the cluster's own (where the work goes, the dashboard, the wait)."""
    return [line for line in err.splitlines() if line.strip() and not line.startswith("cluster: ")]


@pytest.fixture
def scheduler():
    """A Dask scheduler process on loopback, without workers; its address."""
    port = free_port()
    process = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
         "--dashboard-address", "127.0.0.1:0"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    deadline = time.monotonic() + 60
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            break
        except OSError:
            assert process.poll() is None and time.monotonic() < deadline, "the scheduler did not start"
            time.sleep(0.2)
    try:
        yield process, f"127.0.0.1:{port}"
    finally:
        if process.poll() is None:
            process.kill()
        process.wait()


def worker(address: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_worker", f"tcp://{address}", "--nthreads", "1",
         "--nworkers", "1", "--no-dashboard"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip


# Item 3: sbatch that fails ----------------------------------------------------------------------------------
@pytest.mark.parametrize("how", ["no-controller", "broken"])
def test_a_failing_sbatch_is_one_line_before_anything_is_written(tmp_path, how):
    env = dict(os.environ)
    if how == "no-controller":  # Debian's slurm-client with no controller to ask: the real sbatch
        env.pop("SLURM_CONF", None)
        said = "sbatch refuses the worker jobs: sbatch: "
    else:  # an sbatch that fails (a real executable, earlier on PATH)
        bin_dir = tmp_path / "bin"
        bin_dir.mkdir()
        (bin_dir / "sbatch").write_text(
            "#!/bin/sh\necho 'sbatch: error: Batch job submission failed' >&2\nexit 1\n"
        )
        (bin_dir / "sbatch").chmod(0o755)
        env["PATH"] = f"{bin_dir}{os.pathsep}{env['PATH']}"
        said = "sbatch refuses the worker jobs: sbatch: error: Batch job submission failed"
    started = time.monotonic()
    process = evolve(tmp_path / "run", "--evaluations", "50", "--cluster", "slurm", env=env)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 2, err
    no_traceback(err)
    if how == "no-controller" and Path("/etc/slurm/slurm.conf").exists():
        pytest.skip("this machine has a SLURM configuration: sbatch may well work here")
    lines = errors(err)
    assert len(lines) == 1 and lines[0].startswith(f"evolve: error: --cluster slurm: {said}"), err
    assert not (tmp_path / "run").exists()
    assert time.monotonic() - started < 60


# Item 4: a scheduler without workers, Ctrl-C, a scheduler that dies ----------------------------------------
def test_a_scheduler_without_workers_is_waited_for_then_given_up(tmp_path, scheduler):
    _, address = scheduler
    process = evolve(
        tmp_path / "run", "--evaluations", "50", "--cluster", f"dask://{address}", "--worker-wait", "3"
    )
    _, err = process.communicate(timeout=120)
    assert process.returncode == 2, err
    no_traceback(err)
    assert f"cluster: waiting up to 3 s for a worker to join (scheduler tcp://{address}" in err
    assert errors(err) == [
        f"evolve: error: --cluster dask://{address}: no worker joined the scheduler at tcp://{address} in "
        f"3 s; start workers (dask worker tcp://{address}) or give a longer --worker-wait"
    ]
    assert not (tmp_path / "run").exists()


def test_the_worker_wait_has_a_stated_default_and_is_checked():
    from evolution_manager.cluster.settings import WORKER_WAIT
    from evolution_manager.studies.evolve import build_parser

    assert WORKER_WAIT == 300.0 and "default 300" in build_parser().format_help().replace("\n", " ")
    with pytest.raises(ClusterError, match="--worker-wait applies to --cluster dask"):
        from evolution_manager.cluster.settings import settings_from_args

        settings_from_args(build_parser().parse_args(["--out", "x", "--worker-wait", "5"]))


def _stderr_until(process: subprocess.Popen, text: str, seconds: float = 120) -> str:
    seen = ""
    deadline = time.monotonic() + seconds
    while text not in seen:
        assert time.monotonic() < deadline and process.poll() is None, seen
        seen += process.stderr.readline()
    return seen


def test_ctrl_c_while_waiting_for_workers_prints_the_interrupted_line_only(tmp_path, scheduler):
    _, address = scheduler
    process = evolve(tmp_path / "run", "--evaluations", "50", "--cluster", f"dask://{address}")
    seen = _stderr_until(process, "cluster: waiting up to 300 s for a worker to join")
    process.send_signal(signal.SIGINT)
    _, rest = process.communicate(timeout=60)
    assert process.returncode == 130, seen + rest
    no_traceback(seen + rest)
    assert errors(seen + rest) == ["evolve: interrupted before the run started; nothing was written"]
    assert not (tmp_path / "run").exists()


def _started(out: Path, seconds: float = 300) -> None:
    deadline = time.monotonic() + seconds
    while not (out / "evaluations.csv").exists() or (out / "evaluations.csv").stat().st_size < 5000:
        assert time.monotonic() < deadline, "the run did not start"
        time.sleep(0.2)


def test_ctrl_c_mid_run_and_a_scheduler_dying_mid_run_are_one_line_each(tmp_path, scheduler):
    process_of_scheduler, address = scheduler
    helper = worker(address)
    try:
        out = tmp_path / "interrupted"
        process = evolve(out, "--evaluations", "25000", "--cluster", f"dask://{address}")
        _started(out)
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=120)
        assert process.returncode == 130, err
        no_traceback(err)
        assert errors(err) == [f"evolve: interrupted; continue with: evolve --out {out} --resume"]

        out = tmp_path / "lost"
        process = evolve(out, "--evaluations", "25000", "--cluster", f"dask://{address}")
        _started(out)
        process_of_scheduler.kill()
        _, err = process.communicate(timeout=120)
        assert process.returncode == 1, err
        no_traceback(err)
        assert errors(err) == [
            f"evolve: error: the Dask scheduler at tcp://{address} was lost mid-run (the client could not "
            f"reconnect to it); continue with: evolve --out {out} --resume"
        ]
    finally:
        helper.kill()
        helper.wait()


# Dask security of --cluster slurm ---------------------------------------------------------------------------
def _listening(cluster) -> list[str]:
    """The hosts the in-process scheduler's sockets (its comm and its dashboard) are bound to."""
    tcp = cluster.scheduler.listeners[0]
    sockets = [*tcp.tcp_server._sockets.values(), *cluster.scheduler.http_server._sockets.values()]
    return sorted({s.getsockname()[0] for s in sockets})


def test_the_slurm_scheduler_and_dashboard_listen_on_loopback_by_default():
    from dask_jobqueue import SLURMCluster

    options = slurm_cluster_options(SlurmSettings())
    options["scheduler_options"]["dashboard_address"] = "127.0.0.1:0"  # the default's host, any free port
    with SLURMCluster(**options) as slurm:
        assert slurm.scheduler_address.startswith("tcp://127.0.0.1:")
        assert _listening(slurm) == ["127.0.0.1"]  # was 0.0.0.0 and :: for both
        worker_line = next(line for line in slurm.job_script().splitlines() if "dask_worker" in line)
        assert worker_line.endswith("--host 127.0.0.1")
    assert SlurmSettings().dashboard == "127.0.0.1:8787"
    named = slurm_cluster_options(SlurmSettings(interface="lo"))  # the settings name the interface
    assert named["interface"] == "lo" and "worker_extra_args" not in named
    named["scheduler_options"]["dashboard_address"] = None
    with SLURMCluster(**named) as slurm:  # dask-jobqueue binds the scheduler to that interface
        assert slurm.scheduler_address.startswith("tcp://127.0.0.1:")
        assert "--interface lo" in slurm.job_script()


def test_dashboard_and_tls_settings_are_checked(tmp_path):
    config = tmp_path / "cluster.yaml"
    config.write_text("dashboard: none\n")
    assert parse_cluster("slurm", config).slurm.dashboard is None
    config.write_text("dashboard: 0.0.0.0:80800\n")
    with pytest.raises(ClusterError, match=r"dashboard must be HOST:PORT such as 127\.0\.0\.1:8787, or none"):
        parse_cluster("slurm", config)
    config.write_text(f"tls_ca_file: {config}\n")
    with pytest.raises(
        ClusterError, match="tls_cert is missing; TLS takes tls_ca_file, tls_cert and tls_key"
    ):
        parse_cluster("slurm", config)
    config.write_text(f"tls_ca_file: {config}\ntls_cert: {tmp_path / 'no.pem'}\ntls_key: {config}\n")
    with pytest.raises(ClusterError, match="tls_cert must be a readable file"):
        parse_cluster("slurm", config)


def _certificate(folder: Path) -> tuple[Path, Path]:
    """A self-signed certificate (its own CA) and its key, made by openssl."""
    cert, key = folder / "cert.pem", folder / "key.pem"
    subprocess.run(
        ["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", str(key), "-out", str(cert),
         "-days", "1", "-subj", "/CN=swarm-bt-qd-test", "-addext", "subjectAltName=IP:127.0.0.1"],
        check=True,
        capture_output=True,
        timeout=60,
    )  # fmt: skip
    return cert, key


@pytest.mark.skipif(not Path("/usr/bin/openssl").exists(), reason="openssl makes the test's certificate")
def test_with_certificates_the_slurm_scheduler_speaks_tls_only(tmp_path):
    from dask_jobqueue import SLURMCluster

    cert, key = _certificate(tmp_path)
    config = tmp_path / "cluster.yaml"
    config.write_text(f"tls_ca_file: {cert}\ntls_cert: {cert}\ntls_key: {key}\ndashboard: none\n")
    settings = parse_cluster("slurm", config).slurm
    assert settings is not None and settings.tls
    with SLURMCluster(**slurm_cluster_options(settings)) as slurm:
        assert slurm.scheduler_address.startswith("tls://127.0.0.1:")
        script = slurm.job_script()
        assert (
            f"--tls-ca-file {cert}" in script
            and f"--tls-cert {cert}" in script
            and f"--tls-key {key}" in script
        )
        with Client(
            slurm, security=cluster_security(settings), timeout=30
        ) as client:  # TLS, both ways checked
            assert client.scheduler_info()["address"] == slurm.scheduler_address
        plain = slurm.scheduler_address.replace("tls://", "tcp://")
        with pytest.raises((OSError, TimeoutError)):  # no TLS, no certificate: refused
            Client(plain, timeout=3)


@pytest.mark.skipif(not Path("/usr/bin/openssl").exists(), reason="openssl makes the test's certificate")
def test_a_dask_scheduler_that_speaks_tls_is_reached_with_the_settings_certificates(tmp_path):
    """``--cluster dask://HOST:PORT --cluster-config`` with the three ``tls_*`` keys: the command reaches a
    scheduler (and its worker) started with ``--tls-*`` over TLS and runs there. Without the certificates it
    is one line naming what is missing, before anything is written. ``--cluster-config`` was refused with
    ``dask://``, so a scheduler that speaks TLS could not be used at all."""
    cert, key = _certificate(tmp_path)
    tls = ["--tls-ca-file", str(cert), "--tls-cert", str(cert), "--tls-key", str(key)]
    port = free_port()
    scheduler = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
         "--protocol", "tls", "--no-dashboard", *tls],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    worker = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_worker", f"tls://127.0.0.1:{port}", "--nthreads", "1",
         "--nworkers", "1", "--no-dashboard", *tls],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        config = tmp_path / "tls.yaml"
        config.write_text(f"tls_ca_file: {cert}\ntls_cert: {cert}\ntls_key: {key}\n")
        cluster = ["--cluster", f"dask://127.0.0.1:{port}", "--worker-wait", "120"]
        deadline = time.monotonic() + 120
        while True:  # the scheduler takes a while to listen under load
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                assert scheduler.poll() is None and time.monotonic() < deadline, "the scheduler did not start"
                time.sleep(0.2)
        plain = evolve(tmp_path / "plain", "--evaluations", "10", "--trials", "1", *cluster)
        _, err = plain.communicate(timeout=300)
        assert plain.returncode == 2 and errors(err) == [
            f"evolve: error: --cluster dask://127.0.0.1:{port}: something answers there, but not as a Dask "
            "scheduler (a scheduler that speaks TLS needs tls_ca_file, tls_cert and tls_key in "
            "--cluster-config)"
        ], err
        assert not (tmp_path / "plain").exists()
        out = tmp_path / "run"
        run = evolve(out, "--evaluations", "10", "--trials", "1", *cluster, "--cluster-config", str(config))
        _, err = run.communicate(timeout=600)
        no_traceback(err)
        assert run.returncode == 0, err
        assert f"cluster: work goes to the Dask scheduler at tls://127.0.0.1:{port}" in err
        assert (out / "summary.json").exists()
    finally:
        for process in (worker, scheduler):
            if process.poll() is None:
                process.kill()
            process.wait()


def test_distributeds_own_failure_to_cancel_an_interrupted_call_is_not_shown():
    """Ctrl-C before distributed's ``sync`` has begun its call makes its cancel callback fail with a
    ``NameError`` that tornado logs with a traceback, at any moment after the interrupt: that one record is
    dropped, every other error of the loop is kept."""
    import functools
    import logging
    import sys

    from evolution_manager.cluster.client import _INTERRUPTED_SYNC

    def sync():
        def cancel():
            return None

        return cancel

    def record(callback, error):
        try:
            raise error
        except Exception:
            return logging.LogRecord(
                "tornado.application", logging.ERROR, __file__, 1, "Exception in callback %r", (callback,),
                sys.exc_info(),
            )  # fmt: skip

    assert not _INTERRUPTED_SYNC.filter(record(functools.partial(sync()), NameError("future")))
    assert _INTERRUPTED_SYNC.filter(record(functools.partial(sync()), ValueError("other")))
    assert _INTERRUPTED_SYNC.filter(record(print, NameError("elsewhere")))
