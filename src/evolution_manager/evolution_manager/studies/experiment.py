"""``experiment``: every algorithm x objective x run in parallel processes, then the report.

    ws/run evolution_manager experiment --runs 10 --evaluations 25000 --out experiments/paper

GP_o and QD_o run once per objective and run index with ``--evaluations``; GP_fnd runs once per run index
on all three objectives with three times the budget (the paper's 75,000 against 25,000). Run ``r`` of a
configuration gets a seed derived from ``--seed``, the configuration and ``r``.

Under fixed scenarios the ``--design`` says which scenario each run is evaluated on. ``shared`` (the
default, the authors' design: their seeds never change between runs): one scenario seed for every run and
every evaluation of the experiment, ``--scenario-seed`` or one derived from ``--seed``. ``per-run``: each run
its own scenario seed, derived from its run seed. Each run is an
ordinary run directory under ``DIR/runs/<label>/run<r>``; starting the same command again continues
unfinished runs from their checkpoints and leaves finished ones alone. ``experiment.json`` records the
plan, ``sessions.json`` the wall time and commit of every session that ran something, ``runs.csv`` one row
per run and objective (written with the report, in the plan's order, so a killed and continued experiment
writes the same bytes as an uninterrupted one).

Progress covers the whole experiment: individuals produced over all runs against the total budget, with
tqdm's rate and ETA.

Where the runs go: ``--cluster local`` (the default) runs ``--processes`` of them at once in this machine's
processes; ``--cluster dask://HOST:PORT`` or ``--cluster slurm`` (``--cluster-config FILE``) sends each run
whole as one task to the cluster's workers, as many at once as they have threads (``--processes`` is refused
there), with the experiment folder on a filesystem they share (``docs/cluster.md``). The results never
depend on it: ``experiment.json`` holds no cluster setting, so an experiment started here continues on a
cluster and the other way round; ``sessions.json`` records where each session ran.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import os
import queue as queues
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from contextlib import ExitStack
from multiprocessing import get_context, managers
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from bt_controller.draws import MAX_SEED
from bt_controller.language import Library, LibraryError, load_library
from evolution_manager.arguments import (
    EXIT_IO,
    EXIT_USAGE,
    Parser,
    positive_int,
    seconds,
    seed_int,
)
from evolution_manager.cluster.client import open_client
from evolution_manager.cluster.settings import ClusterSettings, add_cluster_options, settings_from_args
from evolution_manager.errors import EvolutionError, UsageError, WriteError
from evolution_manager.evolution.descriptor_sets import DESCRIPTOR_SETS
from evolution_manager.evolution.options import add_scenario_options
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.evolution.run_folder import COMPOSITIONS, NETWORKS, TEAMS
from evolution_manager.files import read_json, read_json_object, write_json
from evolution_manager.processes import (
    die_with_parent,
    exclusive_lock,
    exit_status,
    lock_path_for,
    signals_as_interrupts,
)
from evolution_manager.studies.planning import (
    DESIGNS,
    PLAN_FILE,
    STUDIES,
    Stage,
    differences,
    growth,
    more_runs,
    paper_study,
)
from swarm_ros.safe_paths import refuse_links_within

if TYPE_CHECKING:  # imported where used (run_one): the module is read by every command
    from evolution_manager.evolution.compositions import CompositionConfig, CompositionDirectory
    from swarm_sim.evaluation import Evaluator
    from swarm_sim.model import Config

SESSIONS_FILE = "sessions.json"


def finished(root: Path) -> bool:
    """Whether the run directory ``root`` holds a finished run with its held-out scores."""
    summary_path = Path(root) / "summary.json"
    if not summary_path.exists():
        return False
    summary = read_json(summary_path)
    return isinstance(summary, dict) and bool(summary.get("finished")) and summary.get("heldout") is not None


def produced_so_far(root: Path, budget: int) -> int:
    """Individuals produced by the run in ``root`` at its last checkpoint (the budget when finished)."""
    if finished(root):
        return budget
    checkpoint = Path(root) / "checkpoint.json"
    if not checkpoint.exists():
        return 0
    try:
        state = read_json_object(checkpoint)
        # a tree run keeps its count in its algorithm's state, a composition run at the top
        holder = state.get("algorithm", state)
        return min(budget, int(holder.get("produced", 0)))
    except (EvolutionError, KeyError, TypeError, ValueError, AttributeError):
        return 0


def run_one(
    config_data: dict,
    root: str,
    progress: queues.Queue[tuple[str, int]] | None = None,
    checkpoint_interval: float = 30.0,
) -> str:
    """Run (or finish, or leave alone when finished) one planned run; return its directory.

    A top-level function so that a process pool can call it; each process evaluates on one thread.
    ``progress`` (a queue) receives ``(root, individuals produced)`` after every batch.
    """

    # late: a run's modules (qdpy, DEAP, the simulator, the result writers: about 0.3 s) load in the process
    # that runs it, not in every command that reads this module (evolve, report, the studies)
    from evolution_manager.evolution.run import Run, RunDirectory
    from evolution_manager.evolution.run_results import run_results
    from evolution_manager.viewing.results import write_results
    from swarm_sim.evaluation import BatchEvaluator

    if config_data.get("kind") == COMPOSITIONS:
        return _run_composition(config_data, root, progress, checkpoint_interval)
    if config_data.get("kind") == NETWORKS:
        return _run_network(config_data, root, progress, checkpoint_interval)
    if config_data.get("kind") == TEAMS:
        return _run_team(config_data, root, progress, checkpoint_interval)
    config = RunConfig.from_json(config_data)
    directory = RunDirectory(Path(root))
    if finished(directory.root):
        return root
    if directory.started():
        # the library's file is compared by its digest alone: the study folder may have moved since
        if dataclasses.replace(directory.read_config(), library=config.library) != config:
            raise EvolutionError(f"{root} holds a run of another configuration than the experiment's plan")
        library = directory.read_library(config)  # the run's own copy
    else:
        library = planned_library(config)
    # the run's profile, trial length and library
    evaluator = BatchEvaluator(config.world(), threads=1, library=library)
    if directory.started():
        run = Run.resume(directory.root, evaluator)
    else:
        run = Run.start(config, directory.root, evaluator, library)

    run.execute(on_batch=_reporter(root, progress), checkpoint_interval=checkpoint_interval)
    write_results(run, run_results(run, evaluator), with_figures=False)
    return root


def _same_cells(directory: CompositionDirectory, config: CompositionConfig) -> bool:
    """Whether the cells the composition run in ``directory`` keeps are those its planned sources give now,
    wherever each source run is."""
    from evolution_manager.evolution import compositions as comp  # late, as the run's modules in run_one

    planned, _ = comp.read_sources([Path(source) for source in config.sources])
    kept = [comp.Cell.from_json(c) for c in read_json_object(directory.cells)["cells"]]
    return [dataclasses.replace(c, source="") for c in kept] == [
        dataclasses.replace(c, source="") for c in planned
    ]


def _run_composition(
    config_data: dict,
    root: str,
    progress: queues.Queue[tuple[str, int]] | None,
    checkpoint_interval: float,
) -> str:
    """:func:`run_one` of a planned composition run (``evolution.compositions``): its cells are read from
    its source runs when it starts, and must be the cells the plan recorded."""
    from evolution_manager.evolution import compositions as comp  # late, as the run's modules in run_one
    from swarm_sim.evaluation import BatchEvaluator  # late, as in run_one

    config = comp.CompositionConfig.from_json(config_data)
    directory = comp.CompositionDirectory(Path(root))
    if finished(directory.root):
        return root
    if directory.config.exists():
        saved = comp.CompositionConfig.from_json(read_json_object(directory.config))
        # the source runs are compared by the cells read from them, not by their paths (the study folder
        # may have moved since; each cell, and so the digest, names its source run by path)
        located = dataclasses.replace(saved, sources=config.sources, cells_digest=config.cells_digest)
        if located != config or not _same_cells(directory, config):
            raise EvolutionError(f"{root} holds a run of another configuration than the experiment's plan")
        evaluator = BatchEvaluator(config.world(), threads=1, library=directory.read_library(config))
        run = comp.CompositionRun.resume(directory.root, evaluator)
    else:
        cells, library = comp.read_sources([Path(source) for source in config.sources])
        evaluator = BatchEvaluator(config.world(), threads=1, library=library)
        run = comp.CompositionRun.start(config, cells, directory.root, evaluator, library)

    run.execute(on_batch=_reporter(root, progress), checkpoint_interval=checkpoint_interval)
    run.write_results()
    return root


def _reporter(root: str, progress: queues.Queue[tuple[str, int]] | None) -> Callable[[int, int], None]:
    """A run's ``on_batch``: ``(root, individuals produced)`` into ``progress`` after every batch."""

    def on_batch(produced: int, _budget: int) -> None:
        if progress is not None:
            progress.put((root, produced))

    return on_batch


def _run_network(
    config_data: dict,
    root: str,
    progress: queues.Queue[tuple[str, int]] | None,
    checkpoint_interval: float,
) -> str:
    """:func:`run_one` of a planned network run (``evolution.networks``): started or continued, then its
    summary (with the best network's held-out fitness) and best network written."""
    from evolution_manager.evolution import networks as nets  # late, as the run's modules in run_one

    config = nets.NetworkConfig.from_json(config_data)
    run = _started_or_continued(config, nets.NetworkRun.start, nets.NetworkRun.resume, root)
    if run is not None:
        run.execute(on_batch=_reporter(root, progress), checkpoint_interval=checkpoint_interval)
        run.finish()
    return root


def _run_team(
    config_data: dict,
    root: str,
    progress: queues.Queue[tuple[str, int]] | None,
    checkpoint_interval: float,
) -> str:
    """:func:`run_one` of a planned team run (``evolution.teams``): started or continued, then its summary
    (with the best team's held-out fitness) and best swarm written."""
    from evolution_manager.evolution import teams  # late, as the run's modules in run_one

    config = teams.TeamConfig.from_json(config_data)
    run = _started_or_continued(config, teams.TeamRun.start, teams.TeamRun.resume, root)
    if run is not None:
        run.execute(on_batch=_reporter(root, progress), checkpoint_interval=checkpoint_interval)
        run.write_results()
    return root


class _Planned(Protocol):
    """The configuration of a network or team run: its world, and read from ``config.json``."""

    def world(self) -> Config: ...

    @classmethod
    def from_json(cls, data: dict) -> Any: ...


_Config = TypeVar("_Config", bound=_Planned)
_Run = TypeVar("_Run")


def _started_or_continued(
    config: _Config,
    start: Callable[[_Config, Path, Evaluator], _Run],
    resume: Callable[[Path, Evaluator], _Run],
    root: str,
) -> _Run | None:
    """The planned run of ``config`` (a network or team run) in ``root``: ``start``-ed, or ``resume``-d where
    a run of the same configuration is there; None when it has finished. ``EvolutionError`` when ``root``
    holds a run of another configuration."""
    from swarm_sim.evaluation import BatchEvaluator  # late, as in run_one

    directory = Path(root)
    if finished(directory):
        return None
    evaluator = BatchEvaluator(config.world(), threads=1)
    if (directory / "config.json").exists():
        if type(config).from_json(read_json_object(directory / "config.json")) != config:
            raise EvolutionError(f"{root} holds a run of another configuration than the experiment's plan")
        return resume(directory, evaluator)
    return start(config, directory, evaluator)


def planned_library(config: RunConfig) -> Library | None:
    """The primitive library a planned run starts with (None without one): the file its configuration
    names, which must still be the library of the recorded digest."""
    if not config.library:
        return None
    try:
        library = load_library(config.library)
    except LibraryError as error:
        raise EvolutionError(str(error)) from None
    if library.digest != config.library_digest:
        raise EvolutionError(
            f"{config.library} is no longer the library the experiment planned with (digest "
            f"{library.digest}, expected {config.library_digest})"
        )
    return library


CODE_DIRECTORY = Path(__file__).resolve().parent
"""Where this code is installed: inside the checkout it was built from (``ws/install`` lies in it), which is
not the working directory's when a frozen install runs a study whose folder is in another checkout."""


def current_commit(code: Path = CODE_DIRECTORY) -> str:
    """The commit of the git checkout holding ``code`` ("unknown" outside one), "+" when it has uncommitted
    changes."""
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=True, timeout=10, cwd=code
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            check=True,
            timeout=30,
            cwd=code,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return commit + ("+" if dirty else "")


def record_session(
    directory: Path,
    started: float,
    command: str,
    cluster: ClusterSettings,
    code: Path = CODE_DIRECTORY,
    **more: object,
) -> None:
    """Record this session (wall seconds so far, the commit of the checkout holding ``code``, command, where
    it ran, and ``more``) in ``directory/sessions.json``: appended the first time, updated at every later
    call (so a killed session keeps the time up to its last record; the commit stays the one of the first
    record). ``experiment`` records after every run it finishes, ``evolve`` at its start and end; neither
    file is compared when a run or experiment continues."""
    path = directory / SESSIONS_FILE
    sessions = read_json(path) if path.exists() else []
    assert isinstance(sessions, list)
    commit = None
    if sessions and sessions[-1].get("started_unix") == round(started, 1):
        # The code a session runs is the code it started with: HEAD may move during a long session.
        commit = sessions.pop().get("commit")
    sessions.append(
        {
            "started_unix": round(started, 1),
            "wall_seconds": round(time.time() - started, 1),
            "commit": commit or current_commit(code),
            "command": command,
            "cluster": cluster.to_json(),
            **more,
        }
    )
    write_json(path, sessions)


ORDERS = ("longest", "seed")
"""``--order``'s choices: which of a stage's unfinished runs start first (``start_order``)."""

_RUN_INDEX = re.compile(r"run(\d+)$")


class _Budgeted(Protocol):
    """A planned run's configuration, as far as the start order reads it."""

    @property
    def evaluations(self) -> int: ...


_Budget = TypeVar("_Budget", bound=_Budgeted)


def start_order(runs: Sequence[tuple[_Budget, str]], order: str) -> list[tuple[_Budget, str]]:
    """``runs`` (configuration, run folder) in the order they start: ``longest``, the largest budget first
    (the soonest end of a stage); ``seed``, by the run index of the folder (``.../run03``: 3), then the
    largest budget; ties keep the plan's order. Each run's result is the same whatever the order."""

    def index(folder: str) -> int:
        found = _RUN_INDEX.search(Path(folder).name)
        return int(found.group(1)) if found else 0

    if order == "seed":
        return sorted(runs, key=lambda item: (index(item[1]), -item[0].evaluations))
    return sorted(runs, key=lambda item: -item[0].evaluations)


def build_parser() -> argparse.ArgumentParser:
    """The ``experiment`` command line."""
    parser = Parser(prog="experiment", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--runs", type=positive_int, default=10, help="runs per algorithm and objective (default 10)"
    )
    parser.add_argument(
        "--evaluations",
        type=positive_int,
        default=25_000,
        help="budget of individuals produced per objective (default 25000; GP_fnd 3x)",
    )
    parser.add_argument(
        "--out", type=Path, required=True, help="experiment folder (continued when it exists)"
    )
    parser.add_argument("--seed", type=seed_int, default=0, help="experiment seed (default 0)")
    parser.add_argument("--trials", type=positive_int, default=10, help="trials per evaluation (default 10)")
    add_scenario_options(parser)
    parser.add_argument(
        "--design",
        choices=DESIGNS,
        default="shared",
        help="under fixed scenarios: shared, every run on one scenario (the authors' design, default), or "
        "per-run, each run on its own; in experiment.json",
    )
    parser.add_argument(
        "--processes",
        type=positive_int,
        help="with --cluster local: runs at once (default: this machine's cores)",
    )
    parser.add_argument(
        "--checkpoint-every",
        type=seconds,
        default=30.0,
        metavar="SECONDS",
        help="checkpoint period of each run (default 30)",
    )
    parser.add_argument(
        "--study",
        choices=STUDIES,
        default="paper",
        help="paper: the 2023 paper's three algorithms on its three objectives (default); foraging: the 2024 "
        "study, primitives, libraries and foragers; replication: the 2024 comparison with a library per "
        "primitive seed, from --primitives-from; ablation: the 8-block QD library's ablations, from "
        "--primitives-from; bt-vs-nn: trees against neural networks at equal budget; heterogeneity: "
        "heterogeneous swarms composed from repertoires against the best homogeneous one on the multi-food "
        "tasks; qd-schedule: the foraging study's QD primitives again on the authors' 2024 MAP-Elites "
        "schedule, from --primitives-from (docs/algorithms.md)",
    )
    parser.add_argument(
        "--primitives-from",
        metavar="FOLDER",
        help="with --study replication, ablation or qd-schedule: the foraging study whose primitive runs and "
        "libraries give the libraries (or, for qd-schedule, the runs run again)",
    )
    parser.add_argument(
        "--objectives",
        metavar="O1,O2",
        help="with --study bt-vs-nn: which of its seven objectives (default all: the six primitives and "
        "foraging)",
    )
    parser.add_argument(
        "--swarm-evaluations",
        type=positive_int,
        metavar="N",
        help="with --study heterogeneity: genomes per composition run (default 2000; --evaluations is each "
        "repertoire's trees)",
    )
    parser.add_argument(
        "--tasks",
        metavar="T1,T2",
        help="with --study heterogeneity: which of its tasks to plan, comma-separated (default: its first "
        "three; multifood-arena6-balanced and multifood-arena6-carriers are the fourth and fifth)",
    )
    parser.add_argument(
        "--order",
        choices=ORDERS,
        default="longest",
        help="which of a stage's runs start first: longest, the largest budgets (the soonest end, default); "
        "seed, run 0 of every arm before run 1 (finished runs pair by seed early, so a study stopped midway "
        "can be reported); never changes a result and is not in experiment.json",
    )
    parser.add_argument(
        "--arms",
        metavar="A1,A2",
        help="with --study heterogeneity: which of its arms to plan, comma-separated (default all); each run "
        "keeps the seed it has in the whole plan, so two folders' runs pair by seed",
    )
    parser.add_argument(
        "--descriptors",
        choices=tuple(DESCRIPTOR_SETS),
        help="with --study heterogeneity: the behaviour space of every task's repertoires and compositions "
        "(default: each task's own, the authors' deliveries)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_cluster_options(parser)
    return parser


def run_locally(
    runs: Sequence[tuple[dict, str]],
    processes: int,
    checkpoint_interval: float,
    on_progress: Callable[[str, int], None],
) -> Iterator[tuple[str, BaseException | None]]:
    """Every ``(config_data, root)`` of ``runs`` with :func:`run_one` in ``processes`` processes of this
    machine; yield ``(root, None)`` as each run finishes, ``(root, error)`` for one that failed (the others go
    on), as ``cluster.runs.map_runs`` does on a cluster. ``on_progress(root, produced)`` between results."""
    # The manager's server process is spawned, not forked: a forked one would share the experiment
    # folder's lock (flock holds while any process has the file open) and could outlive a killed experiment
    # by a moment, so that continuing it at once was refused as "in use".
    with SyncManager(ctx=get_context("spawn")) as manager:
        progress = manager.Queue()
        workers = manager.list()
        pool = ProcessPoolExecutor(
            max_workers=processes,
            mp_context=get_context("spawn"),
            initializer=_start_worker,
            initargs=(workers,),
        )
        try:
            futures = {
                pool.submit(run_one, config_data, root, progress, checkpoint_interval): root
                for config_data, root in runs
            }
            pending = set(futures)
            while pending:
                completed, pending = wait(pending, timeout=1.0, return_when=FIRST_COMPLETED)
                _drain(progress, on_progress)
                for future in completed:
                    yield futures[future], future.exception()
        except BaseException:
            # Interrupted (Ctrl-C, SIGTERM) or failing: stop the runs under way at once rather than wait for
            # them; each continues from its last checkpoint (a killed run resumes to the same bytes).
            try:
                pids = list(workers)
            except (OSError, EOFError):
                # the signal went to the whole process group (Ctrl-C in a terminal, `timeout`) and stopped
                # the manager too; the workers got it as well, and die with this process in any case
                pids = []
            for pid in pids:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


def _start_worker(workers: managers.ListProxy[int]) -> None:
    """A pool worker's start: it dies with the experiment's process, whatever kills that (no run goes on
    adopted by PID 1), and says its PID so that an interrupted experiment can stop it."""
    die_with_parent()
    workers.append(os.getpid())


class SyncManager(managers.SyncManager):
    """``multiprocessing.Manager()`` whose server process dies with the experiment's process."""

    def start(
        self, initializer: Callable[..., object] | None = None, initargs: Iterable[object] = ()
    ) -> None:
        super().start(initializer or die_with_parent, initargs)


def experiment(argv: Sequence[str] | None = None) -> int:
    """Run ``experiment``; return the exit status."""
    try:
        args = build_parser().parse_args(argv)
        cluster = settings_from_args(args)
        if args.processes is not None and not cluster.is_local:
            raise UsageError(
                f"--processes applies to --cluster local only; on {cluster.describe()} every worker thread "
                "runs one run at a time"
            )
        if not 0 <= args.seed <= MAX_SEED:
            raise UsageError(f"--seed must be in [0, {MAX_SEED}], got {args.seed}")
        if args.scenario_seed is not None and args.scenarios == "fresh":
            raise UsageError("--scenario-seed applies to --scenarios fixed; leave it out with fresh")
        if args.scenario_seed is not None and not 0 <= args.scenario_seed <= MAX_SEED:
            raise UsageError(f"--scenario-seed must be in [0, {MAX_SEED}], got {args.scenario_seed}")
        # One experiment command per folder, refused up front as evolve refuses a second run on its folder:
        # two would plan, run and report into one folder at once. The lock is kept outside the folder (it
        # may not exist yet; nothing is written into it before the options are checked), for this process's
        # life.
        exclusive_lock(lock_path_for(args.out, "experiment"), f"the experiment folder {args.out}")
        scenarios = args.scenarios or "fixed"
        design = args.design if scenarios == "fixed" else None  # fresh: every evaluation its own scenario
        if args.primitives_from is not None and args.study not in ("replication", "ablation", "qd-schedule"):
            raise UsageError(
                "--primitives-from applies to --study replication, ablation and qd-schedule only"
            )
        if args.objectives is not None and args.study != "bt-vs-nn":
            raise UsageError("--objectives applies to --study bt-vs-nn only")
        if args.swarm_evaluations is not None and args.study != "heterogeneity":
            raise UsageError("--swarm-evaluations applies to --study heterogeneity only")
        for name in ("tasks", "arms", "descriptors"):
            if getattr(args, name) is not None and args.study != "heterogeneity":
                raise UsageError(f"--{name} applies to --study heterogeneity only")
        if args.study == "foraging":
            from evolution_manager.studies import foraging_study  # late: loads scipy.stats (about 1 s)

            document, stages, budgets = foraging_study.plan_study(args, scenarios, design)
            report: Callable[[Path], Path] = foraging_study.build_report
        elif args.study == "replication":
            from evolution_manager.studies import replication_study  # late: loads scipy.stats (about 1 s)

            document, stages, budgets = replication_study.plan_study(args, scenarios, design)
            report = replication_study.build_report
        elif args.study == "bt-vs-nn":
            from evolution_manager.studies import networks_study  # late: loads scipy.stats (about 1 s)

            document, stages, budgets = networks_study.plan_study(args, scenarios, design)
            report = networks_study.build_report
        elif args.study == "heterogeneity":
            from evolution_manager.studies import heterogeneity_study  # late: loads scipy.stats (about 1 s)

            document, stages, budgets = heterogeneity_study.plan_study(args, scenarios, design)
            report = heterogeneity_study.build_report
        elif args.study == "ablation":
            from evolution_manager.studies import ablation_study  # late: loads scipy.stats (about 1 s)

            document, stages, budgets = ablation_study.plan_study(args, scenarios, design)
            report = ablation_study.build_report
        elif args.study == "qd-schedule":
            from evolution_manager.studies import schedule_study  # late: loads scipy.stats (about 1 s)

            document, stages, budgets = schedule_study.plan_study(args, scenarios, design)
            report = schedule_study.build_report
        else:
            from evolution_manager.studies import (
                report as paper_report,  # late: its figures load matplotlib (about 1.5 s)
            )

            document, stages, budgets = paper_study(args, scenarios, design)
            report = paper_report.build_report
        plan_path = args.out / PLAN_FILE
        if plan_path.exists():
            saved = read_json(plan_path)
            given = json.loads(json.dumps(document))
            if saved != given and more_runs(saved, given):
                print(
                    f"experiment: {args.out} grows {growth(saved, given)}; "
                    "the runs it planned keep their seeds and folders",
                    file=sys.stderr,
                )
            elif saved != given:
                raise UsageError(
                    f"{args.out} holds an experiment with other options ({differences(saved, given)}); "
                    "use the same options to continue it, or another --out"
                )
        elif args.out.exists() and any(args.out.iterdir()):
            raise UsageError(f"{args.out} exists and is not an experiment folder; choose another --out")
        # The folder holds nothing but what experiments made, and they make no links: a link planted at any
        # depth (runs/, a group's folder, a run, the report, figures/) is refused before anything is run or
        # written; a link at runs/ or a group's folder sent its runs outside the folder.
        refuse_links_within(args.out)
    except (UsageError, EvolutionError) as error:  # a ClusterError too
        print(f"experiment: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:  # an --out that cannot be read
        print(f"experiment: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    command = "ws/run evolution_manager experiment " + " ".join(argv if argv is not None else sys.argv[1:])
    status = execute(args, cluster, command, document, stages, budgets)
    if status != 0:
        return status
    try:
        written = report(args.out)
    except EvolutionError as error:
        print(f"experiment: error: the report cannot be written: {error}", file=sys.stderr)
        return 1
    print(f"experiment: {sum(1 for _ in budgets)} runs in {args.out}; report: {written}")
    return 0


def execute(
    args: argparse.Namespace,
    cluster: ClusterSettings,
    command: str,
    document: dict,
    stages: Sequence[Stage],
    budgets: dict[str, int],
) -> int:
    """Write the plan ``document`` and run every stage's runs in turn (those not finished), with one progress
    bar over ``budgets`` (individuals per run directory, relative to ``args.out``); the exit status. A stage
    starts only when every run before it has finished."""
    started = time.time()
    out = args.out.absolute()  # a cluster's workers need the whole path (the same on every machine)
    plan_path = args.out / PLAN_FILE
    total = {str(out / path): budget for path, budget in budgets.items()}
    done = {root: produced_so_far(Path(root), budget) for root, budget in total.items()}
    already = sum(1 for root in total if finished(Path(root)))
    bar = None
    failures: list[str] = []
    full_disk = False  # a run could not write its files: what each saved is whole, the command continues it
    finished_now = 0

    def say(line: str) -> None:
        print(f"experiment: {line}", file=sys.stderr, flush=True)

    def show() -> None:
        if bar is not None:
            bar.n = sum(done.values())
            bar.set_description(f"experiment ({already + finished_now}/{len(total)} runs)")
            bar.refresh()

    def on_progress(root: str, produced: int) -> None:
        done[root] = max(done.get(root, 0), int(produced))
        show()

    try:
        with ExitStack() as stack:
            stack.enter_context(signals_as_interrupts())  # SIGTERM stops it as Ctrl-C does
            try:
                client = stack.enter_context(open_client(cluster, say=say))
                args.out.mkdir(parents=True, exist_ok=True)
                write_json(plan_path, document)
            except EvolutionError as error:  # no scheduler answers, no SLURM; the plan not written
                print(f"experiment: error: {error}", file=sys.stderr)
                return EXIT_USAGE
            except OSError as error:  # an --out that cannot be created or written
                print(f"experiment: error: {error}", file=sys.stderr)
                return EXIT_USAGE
            if not args.no_progress:
                from tqdm import tqdm  # late: about 70 ms, only when a bar is shown

                bar = stack.enter_context(
                    tqdm(
                        total=sum(total.values()),
                        initial=sum(done.values()),
                        unit="ind",
                        desc=f"experiment ({already}/{len(total)} runs)",
                        dynamic_ncols=True,
                        disable=None,
                    )
                )
            for stage in stages:
                try:
                    planned = stage()
                except EvolutionError as error:  # e.g. a library cannot be built from the stage before
                    print(f"experiment: error: {error}", file=sys.stderr)
                    return 1
                paths = {str(out / path): path for _, path in planned}
                to_run = [(config, str(out / path)) for config, path in planned if not finished(out / path)]
                to_run = start_order(to_run, args.order)
                runs = [(config.to_json(), root) for config, root in to_run]
                if client is None:
                    processes = args.processes or os.cpu_count() or 1
                    results = run_locally(runs, processes, args.checkpoint_every, on_progress)
                else:
                    from evolution_manager.cluster.runs import map_runs  # loads Dask: only for a cluster

                    results = map_runs(client, run_one, runs, args.checkpoint_every, on_progress=on_progress)
                for root, problem in results:
                    if problem is None:
                        finished_now += 1
                        done[root] = total[root]
                        record_session(args.out, started, command, cluster, runs_finished=finished_now)
                    else:  # a failed run is reported, the others go on
                        failures.append(f"{paths[root]}: {problem}")
                        full_disk = full_disk or isinstance(problem, WriteError)
                    show()
                if failures:  # the next stage builds on every run of this one
                    break
    except KeyboardInterrupt as interruption:
        print(
            f"experiment: interrupted; run the same command again to continue ({args.out})", file=sys.stderr
        )
        return exit_status(interruption)
    if failures:
        print("experiment: some runs failed:\n  " + "\n  ".join(failures), file=sys.stderr)
        if full_disk:
            print(
                f"experiment: make room, then run the same command again to continue ({args.out})",
                file=sys.stderr,
            )
            return EXIT_IO
        return 1
    return 0


def _drain(progress: queues.Queue[tuple[str, int]], on_progress: Callable[[str, int], None]) -> None:
    """Hand every progress message waiting in the queue to ``on_progress``."""
    while True:
        try:
            root, produced = progress.get_nowait()
        except queues.Empty:
            return
        on_progress(root, produced)


def main() -> None:
    """Console entry point of ``experiment``."""
    sys.exit(experiment())
