"""The cost of Dask on this machine (a benchmark that prints figures, never a test).

    ws/run evolution_manager measure-cluster [--evaluations 6000] [--chunk 25] [--slurm-runs 8]

1. Per-task overhead: a Dask cluster of one worker process (one thread) on this machine; empty tasks sent one
   at a time (the round trip) and many at once (the scheduler's throughput), and a chunk of ``--chunk``
   evaluations through Dask against the same chunk in-process.
2. One run (MAP-Elites on food, the paper's batches) stopped after ``--evaluations`` evaluations, in-process
   against through that one-worker Dask, ``--pairs`` times each way in the order ABBA: wall time and
   throughput ratio (the goal: Dask at >= 95 % of in-process), and a check that every run's evaluation log is
   the same bytes.
3. With ``--slurm-runs N`` and a SLURM reachable (``SLURM_CONF``; tests/slurm_cluster.py starts a one-node
   one): an experiment of N small runs through SLURM jobs of one core each (as many jobs as this machine has
   cores, started by dask-jobqueue) against the same runs in local processes; wall times, cluster start
   included, and a check that every run's files are the same bytes.

Timings depend on the load of the machine (printed): compare figures of one invocation.
"""

from __future__ import annotations

import argparse
import logging
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path
from typing import TYPE_CHECKING

from bt_controller.language import random_trees
from evolution_manager.arguments import EXIT_USAGE, Parser, positive_int
from evolution_manager.cluster.client import open_client
from evolution_manager.cluster.settings import ClusterSettings, SlurmSettings
from evolution_manager.errors import UsageError
from evolution_manager.evolution.run import Run
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.studies.experiment import run_one
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, Evaluator
from swarm_sim.model import default_config

PROFILE = "paper"

if TYPE_CHECKING:  # Dask loads where the benchmark uses it
    from distributed import Client


def _noop(x: int) -> int:
    return x


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} cores"


def task_overhead(client: Client, tasks: int, chunk: int) -> dict[str, float]:
    """Milliseconds per empty task (round trip, and pipelined) and per chunk of ``chunk`` evaluations."""
    # Dask (about 0.3 s to import) loads only for a cluster
    from evolution_manager.cluster.evaluator import (
        evaluate_chunk,
        worker_evaluator,
    )

    c = client
    for k in range(20):  # warm the connection
        c.submit(_noop, k, pure=False).result()
    started = time.perf_counter()
    for k in range(tasks):
        c.submit(_noop, k, pure=False).result()
    round_trip = (time.perf_counter() - started) / tasks
    started = time.perf_counter()
    c.gather(c.map(_noop, range(tasks), pure=False))
    pipelined = (time.perf_counter() - started) / tasks
    payloads = [(tree, 7, 10) for tree in random_trees(5, chunk)]
    local, remote = [], []
    worker_evaluator(PROFILE).evaluate([EvaluationRequest(payloads[0][0], 7, 10)])  # kernels loaded here too
    for _ in range(10):
        started = time.perf_counter()
        evaluate_chunk(PROFILE, payloads)
        local.append(time.perf_counter() - started)
        started = time.perf_counter()
        c.submit(evaluate_chunk, PROFILE, payloads, pure=False).result()
        remote.append(time.perf_counter() - started)
    return {
        "round_trip_ms": 1000 * round_trip,
        "pipelined_ms": 1000 * pipelined,
        "chunk_local_ms": 1000 * statistics.median(local),
        "chunk_dask_ms": 1000 * statistics.median(remote),
    }


def one_run(evaluator: Evaluator, root: Path, evaluations: int) -> float:
    """Wall seconds of a MAP-Elites run on food stopped after ``evaluations`` evaluations."""
    config = RunConfig.make("qd", "food", 25_000, seed=1, profile=PROFILE)
    run = Run.start(config, root, evaluator)
    started = time.perf_counter()
    run.execute(stop_after=evaluations, checkpoint_interval=30.0)
    wall = time.perf_counter() - started
    if run.lock is not None:
        run.lock.release()
    return wall


def run_comparison(client: Client, evaluations: int, chunk: int, work: Path, pairs: int) -> dict[str, float]:
    """In-process against one-worker Dask for the same run, ``pairs`` times in the order ABBA... (so that a
    load that drifts weighs on both alike); raise if any two runs' evaluation logs differ."""
    # Dask (about 0.3 s to import) loads only for a cluster
    from evolution_manager.cluster.evaluator import (
        WARM_UP_TREE,
        DaskEvaluator,
    )

    local = BatchEvaluator(default_config(PROFILE))
    local.evaluate([EvaluationRequest(WARM_UP_TREE, 0, 1)])  # kernels loaded before the clock, as ...
    dask = DaskEvaluator(client, PROFILE, chunk)  # ... on the worker (its plugin)
    evaluators: dict[str, Evaluator] = {"local": local, "dask": dask}
    seconds: dict[str, list[float]] = {"local": [], "dask": []}
    order = [("local", "dask"), ("dask", "local")]
    for k in range(pairs):
        for name in order[k % 2]:
            seconds[name].append(one_run(evaluators[name], work / f"{name}{k}", evaluations))
            print(f"  {name}: {seconds[name][-1]:.1f} s ({_load()})", flush=True)
    logs = {(work / f"{name}{k}" / "evaluations.csv").read_bytes() for name in seconds for k in range(pairs)}
    if len(logs) != 1:
        raise RuntimeError("the runs through Dask logged other evaluations than the runs in-process")
    return {"local_s": sum(seconds["local"]), "dask_s": sum(seconds["dask"]), "tasks": dask.tasks / pairs}


def slurm_comparison(runs: int, evaluations: int, work: Path) -> dict[str, float]:
    """``runs`` small runs in local processes against SLURM jobs (one core each, as many as cores)."""
    # Dask (about 0.3 s to import) loads only for a cluster
    from evolution_manager.cluster.runs import map_runs

    cores = os.cpu_count() or 1
    configs = [
        RunConfig.make("qd" if k % 2 else "gp", ("density", "nest", "food")[k % 3], evaluations, 100 + k, 10)
        for k in range(runs)
    ]
    started = time.perf_counter()
    with ProcessPoolExecutor(max_workers=cores, mp_context=get_context("spawn")) as pool:
        roots = [str(work / "local" / f"r{k}") for k in range(runs)]
        list(pool.map(run_one, [c.to_json() for c in configs], roots))
    t_local = time.perf_counter() - started
    settings = ClusterSettings("slurm", slurm=SlurmSettings(cores=1, memory="1GB", jobs=cores))
    started = time.perf_counter()
    with open_client(settings) as client:
        planned = [(c.to_json(), str(work / "slurm" / f"r{k}")) for k, c in enumerate(configs)]
        assert client is not None  # slurm settings
        failed = [(root, error) for root, error in map_runs(client, run_one, planned) if error is not None]
    t_slurm = time.perf_counter() - started
    if failed:
        raise RuntimeError(f"runs failed on SLURM: {failed}")
    for k in range(runs):
        a, b = work / "local" / f"r{k}" / "evaluations.csv", work / "slurm" / f"r{k}" / "evaluations.csv"
        if a.read_bytes() != b.read_bytes():
            raise RuntimeError(f"run {k} logged other evaluations on SLURM than locally")
    return {"local_s": t_local, "slurm_s": t_slurm}


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="measure-cluster", description=__doc__.split("\n")[0])
    parser.add_argument("--evaluations", type=positive_int, default=6000, help="of the run (default 6000)")
    parser.add_argument("--chunk", type=positive_int, default=25, help="evaluations per task (default 25)")
    parser.add_argument("--tasks", type=positive_int, default=300, help="empty tasks timed (default 300)")
    parser.add_argument("--pairs", type=positive_int, default=2, help="runs each way, ABBA (default 2)")
    parser.add_argument("--slurm-runs", type=int, default=0, help="runs compared on SLURM (default: none)")
    parser.add_argument("--slurm-evaluations", type=positive_int, default=300, help="each (default 300)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
    except UsageError as error:
        print(f"measure-cluster: error: {error}", file=sys.stderr)
        return EXIT_USAGE

    # Dask (about 0.3 s to import) loads only for a cluster
    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.WARNING)
    print(f"measure-cluster: {_load()}", flush=True)
    with (
        tempfile.TemporaryDirectory(prefix="cluster-bench-") as tmp,
        LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster,
        Client(cluster) as client,
    ):
        o = task_overhead(client, args.tasks, args.chunk)
        print(
            f"per task: {o['round_trip_ms']:.2f} ms round trip, {o['pipelined_ms']:.2f} ms pipelined; "
            f"a chunk of {args.chunk} evaluations: {o['chunk_local_ms']:.1f} ms in-process, "
            f"{o['chunk_dask_ms']:.1f} ms through Dask (+{o['chunk_dask_ms'] - o['chunk_local_ms']:.1f} ms)",
            flush=True,
        )
        r = run_comparison(client, args.evaluations, args.chunk, Path(tmp), args.pairs)
        print(
            f"one run of {args.evaluations} evaluations, {args.pairs} times each way: {r['local_s']:.1f} s "
            f"in-process, {r['dask_s']:.1f} s through Dask with one worker ({r['tasks']:.0f} tasks per "
            "run); "
            f"throughput through Dask {100 * r['local_s'] / r['dask_s']:.1f} % of in-process (goal >= 95 %); "
            "same evaluations.csv",
            flush=True,
        )
    if args.slurm_runs > 0:
        with tempfile.TemporaryDirectory(prefix="cluster-bench-") as tmp:
            s = slurm_comparison(args.slurm_runs, args.slurm_evaluations, Path(tmp))
        print(
            f"an experiment of {args.slurm_runs} runs of {args.slurm_evaluations} evaluations: "
            f"{s['local_s']:.1f} s in {os.cpu_count()} local processes, {s['slurm_s']:.1f} s on "
            f"{os.cpu_count()} SLURM jobs (their start included); same evaluations.csv in every run",
            flush=True,
        )
    print(f"measure-cluster: {_load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
