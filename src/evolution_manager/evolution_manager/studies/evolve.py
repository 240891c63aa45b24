"""``evolve``: run one algorithm on one objective (or GP_fnd on all three) and write a run directory.

    ws/run evolution_manager evolve --algorithm qd --objective food --evaluations 25000 --seed 1 --out runs/qd
    ws/run evolution_manager evolve --out runs/qd --resume        # continue a killed or interrupted run
    ws/run evolution_manager evolve --task foraging --swarm-from runs/qd runs/qd-nest --algorithm ga \
        --evaluations 1000 --out runs/compositions     # a repertoire cell per robot (evolution.compositions)
    ws/run evolution_manager evolve --algorithm nn-cmaes --objective food --evaluations 25000 --seed 1 \
        --out runs/nn    # the 9-5-1 network's weights: CMA-ES, the GA (nn-ga) or MAP-Elites (nn-qd)
    ws/run evolution_manager evolve --team 2 --algorithm gp --task multifood-arena9-kind2 \
        --objective foraging_biased --out runs/team2    # 2 trees evolved together (evolution.teams)

Bad options print one line saying what was expected and exit with status 2; nothing already saved is
touched. An interrupted run (Ctrl-C) exits with status 130 and continues with ``--resume``.

``--cluster dask://HOST:PORT`` or ``--cluster slurm`` (``--cluster-config FILE``) sends each batch, and the
held-out scores at the end, to a Dask cluster's workers in chunks (``cluster.evaluator.DaskEvaluator``)
instead of this process's evaluator (``--workers`` threads, refused with a cluster). The run's files are the
same bytes either way, and ``config.json`` holds no cluster setting: a run started here continues on a
cluster and the other way round. ``sessions.json`` in the run directory records each session: its wall
time, commit, command and where it ran.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from evolution_manager.arguments import (
    EXIT_IO,
    EXIT_USAGE,
    Parser,
    positive_int,
    seconds,
    seed_int,
    tree_argument,
)
from evolution_manager.cluster.client import open_client
from evolution_manager.cluster.settings import add_cluster_options, settings_from_args
from evolution_manager.errors import DispatchError, EvolutionError, UsageError, WriteError
from evolution_manager.evolution.options import (
    add_scenario_options,
    add_task_options,
    check_resume_options,
    check_scenario_seed,
    config_from_args,
    library_from_args,
    progress_bar,
)
from evolution_manager.evolution.run_config import ALGORITHMS, DEFAULT_EVALUATIONS, OBJECTIVES
from evolution_manager.evolution.run_folder import COMPOSITIONS, NETWORKS, TEAMS, run_kind
from evolution_manager.files import read_json, read_json_object
from evolution_manager.processes import exit_status, signals_as_interrupts
from swarm_ros.safe_paths import UnsafePathError, describe
from swarm_sim.tasks import registered_name, task_label, task_named

if TYPE_CHECKING:  # imported where used: Dask, tqdm and a run's modules load late (see _evolve)
    from distributed import Client
    from tqdm import tqdm

    from bt_controller.language import Library
    from evolution_manager.cluster.settings import ClusterSettings
    from evolution_manager.evolution.compositions import CompositionParameters
    from swarm_sim.evaluation import Evaluator
    from swarm_sim.model import Config


NETWORK_ALGORITHMS = ("nn-cmaes", "nn-ga", "nn-qd")
"""The optimisers over a network's weights (``evolution.networks.ALGORITHMS``: that module loads late)."""
COMPOSITION_ALGORITHMS = ("ga", "qd", "ascent")
"""The optimisers over compositions (``evolution.compositions.ALGORITHMS``: that module loads late); ``qd``
is a tree run's too, so only ``--swarm-from`` makes it a composition run."""


def build_parser() -> argparse.ArgumentParser:
    """The ``evolve`` command line."""
    parser = Parser(prog="evolve", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--algorithm",
        choices=tuple(dict.fromkeys((*ALGORITHMS, *COMPOSITION_ALGORITHMS, *NETWORK_ALGORITHMS))),
        help="gp (GP_o), gp-fnd (GP_fnd) or qd (MAP-Elites); with --swarm-from, ga, qd or ascent (coordinate "
        "ascent over the groups' cells) over compositions; "
        "nn-cmaes, nn-ga or nn-qd (MAP-Elites): the weights of the 9-5-1 network controller",
    )
    parser.add_argument(
        "--objective", choices=OBJECTIVES, help="the objective of gp and qd (gp-fnd: --objectives)"
    )
    budgets = ", ".join(f"{a} {n}" for a, n in DEFAULT_EVALUATIONS.items())
    parser.add_argument(
        "--evaluations",
        type=positive_int,
        help=f"budget of individuals produced after the initial population (default: {budgets})",
    )
    parser.add_argument("--seed", type=seed_int, help="run seed, an integer in [0, 2**63 - 1] (default 0)")
    parser.add_argument("--trials", type=positive_int, help="trials per evaluation (default 10)")
    add_scenario_options(parser)
    add_task_options(parser)
    parser.add_argument(
        "--out", type=Path, required=True, help="run directory (must not hold a run, unless --resume)"
    )
    parser.add_argument(
        "--workers", type=positive_int, help="with --cluster local: evaluator threads (default 1)"
    )
    parser.add_argument(
        "--resume", action="store_true", help="continue the run in --out from its last checkpoint"
    )
    parser.add_argument(
        "--checkpoint-every",
        type=seconds,
        default=30.0,
        metavar="SECONDS",
        help="checkpoint period (default 30)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-figures", action="store_true", help="write results but no figures")
    parser.add_argument(
        "--swarm-from",
        nargs="+",
        type=Path,
        metavar="RUN_DIR",
        help="evolve compositions (a repertoire cell per robot; --task TASK, --algorithm ga, qd or ascent) "
        "of the repertoires in these run directories (docs/algorithms.md, 'Heterogeneous compositions')",
    )
    parser.add_argument(
        "--swarm-mutation",
        choices=("one", "all", "axis"),
        help="with --swarm-from: how a child is mutated, one of the authors' three: one robot's cell "
        "redrawn (one, the default), each robot's with probability 0.5 (all), each robot's moved along one "
        "axis of its source repertoire (axis)",
    )
    parser.add_argument(
        "--swarm-crossover",
        choices=("two-point", "mix"),
        help="with --swarm-from: two-point crossover (the default) or, with --algorithm qd, Mix-ME's "
        "mixing of two genomes of different bins (mix)",
    )
    parser.add_argument(
        "--swarm-groups",
        type=positive_int,
        metavar="K",
        help="with --swarm-from: the robots in K groups (robot i in group i mod K), each group running one "
        "cell, so the search is over K cells (default: a cell per robot, as the authors'; K >= 2, and at "
        "least 3 for two-point crossover)",
    )
    parser.add_argument(
        "--homogeneous",
        type=positive_int,
        metavar="K",
        help="with --swarm-from: start from the homogeneous swarms of the K fittest cells besides random "
        "genomes (default 0: all random, as the authors' GA)",
    )
    parser.add_argument(
        "--team",
        type=int,
        metavar="K",
        help="with --algorithm gp: evolve K trees together, robot i running tree i mod K "
        "(docs/algorithms.md, 'Teams')",
    )
    parser.add_argument(
        "--start-tree",
        metavar="TREE",
        action="append",
        help="with --team K: start from this tree (text, or a file holding it) in every sub-group of every "
        "team of the initial population, instead of random trees; given K times, sub-group g starts from the "
        "g-th",
    )
    add_cluster_options(parser)
    return parser


class _HasWorld(Protocol):
    def world(self) -> Config: ...


def _evaluator(
    workers: int | None, config: _HasWorld, library: Library | None = None, client: Client | None = None
) -> Evaluator:
    """The run's evaluator of the run's world (profile and trial length) and library: the cluster's workers
    through ``client``, else ``workers`` threads here (every kind of run)."""
    if client is not None:
        # Dask (about 0.3 s to import) loads only for a cluster
        from evolution_manager.cluster.evaluator import DaskEvaluator

        return DaskEvaluator(client, config.world(), library=library)
    from swarm_sim.evaluation import BatchEvaluator  # late, as the run's modules (see _evolve)

    try:
        return BatchEvaluator(config.world(), threads=workers or 1, library=library)
    except ValueError as error:
        raise UsageError(f"--workers: {error}") from None


def _holds_a_run(out: Path) -> bool:
    """Whether ``out`` holds a run (its ``config.json``, written when the run directory is made)."""
    return (Path(out) / "config.json").exists()


def _refuse_a_started_run(out: Path) -> None:
    """Raise ``UsageError`` when ``out`` holds a run already: a new run is never started over it."""
    if _holds_a_run(out):
        raise UsageError(f"{out} already holds a run: add --resume to continue it, or use another --out")


def evolve(argv: Sequence[str] | None = None) -> int:
    """Run ``evolve``; return the exit status."""
    given: dict[str, Path] = {}  # the run directory, once the options are read
    # Ctrl-C and SIGTERM raise from the start, so that one arriving between the steps that answer it
    # themselves (after a run directory is made, before the run executes) still ends in one line; the
    # stack holds the cluster's client, open until the results are written
    with ExitStack() as stack, signals_as_interrupts():
        try:
            status = _evolve(argv, stack, given)
        except KeyboardInterrupt as interruption:
            out = given.get("out")
            if out is not None and _holds_a_run(out):
                print(f"evolve: interrupted; continue with: evolve --out {out} --resume", file=sys.stderr)
            else:
                print("evolve: interrupted before the run started; nothing was written", file=sys.stderr)
            status = exit_status(interruption)
    return status


_SWARM_OPTIONS = {
    "cell_mutation": "swarm-mutation",
    "crossover_operator": "swarm-crossover",
    "groups": "swarm-groups",
}
"""The options that vary compositions, by the ``CompositionParameters`` field each sets."""


def _evolve(argv: Sequence[str] | None, stack: ExitStack, given: dict[str, Path]) -> int:
    started = time.time()
    out: Path | None = None  # known once the options are read
    try:
        args = build_parser().parse_args(argv)
        out = given["out"] = args.out
        cluster = settings_from_args(args)
        check_scenario_seed(args)  # before anything: -1 is not "derive it", for tree and composition runs
        if _teams_asked(args):
            return _evolve_teams(args, argv, started, cluster)
        if args.start_tree is not None:
            raise UsageError("--start-tree seeds the teams of a team run: it goes with --team K")
        if _compositions_asked(args):
            return _evolve_compositions(args, argv, started, cluster)
        if _networks_asked(args):
            return _evolve_networks(args, argv, started, cluster)
        if args.homogeneous is not None:
            raise UsageError(
                "--homogeneous seeds compositions of repertoire cells: it goes with --swarm-from RUN_DIR"
            )
        for option in _SWARM_OPTIONS.values():
            if getattr(args, option.replace("-", "_")) is not None:
                raise UsageError(
                    f"--{option} varies compositions of repertoire cells: it goes with --swarm-from"
                )
        if args.workers is not None and not cluster.is_local:
            raise UsageError(
                f"--workers applies to --cluster local only; on {cluster.describe()} the batches go to "
                "every worker thread"
            )
        config = None if args.resume else config_from_args(args)
        # late: a run's modules (qdpy, DEAP, the simulator, the result writers: about 0.3 s) load once the
        # options are accepted, so that --help and a refused option answer at once
        from evolution_manager.evolution.run import Run, RunDirectory
        from evolution_manager.evolution.run_results import run_results
        from evolution_manager.viewing.results import write_results

        directory = RunDirectory(args.out)
        if args.resume:
            if not directory.started():
                raise UsageError(f"--resume: {args.out} holds no run to continue (no config.json)")
            saved = directory.read_config()
            check_resume_options(args, saved)
            config = saved
            library = directory.read_library(saved)
        else:
            _refuse_a_started_run(args.out)
            assert config is not None  # made from the options when not resuming
            library = library_from_args(args)
        # Ctrl-C or SIGTERM while waiting for a cluster's workers: one line (the handler is evolve's)
        client = stack.enter_context(open_client(cluster, say=lambda line: print(line, file=sys.stderr)))
        evaluator = _evaluator(args.workers, config, library, client)
        if args.resume:
            run = Run.resume(args.out, evaluator)
        else:
            run = Run.start(config, args.out, evaluator, library)
    except (WriteError, UsageError, EvolutionError, OSError) as error:
        return _could_not_start(error, out)
    except KeyboardInterrupt as interruption:  # before the run started (waiting for a cluster's workers)
        print("evolve: interrupted before the run started; nothing was written", file=sys.stderr)
        return exit_status(interruption)
    bar = progress_bar(run.config, run.evaluations, not args.no_progress)

    def on_batch(done: int, total: int) -> None:
        if bar is not None:
            bar.update(done - bar.n)
            best = [run.passive[o].best_value for o in run.config.objectives]
            bar.set_postfix_str(
                " ".join(
                    f"{o}={b:.3f}" for o, b in zip(run.config.objectives, best, strict=True) if b is not None
                )
            )

    failed = _execute(
        run,
        lambda: write_results(run, run_results(run, run.evaluator), with_figures=not args.no_figures),
        args,
        argv,
        started,
        cluster,
        bar,
        on_batch,
    )
    if failed is not None:
        return failed
    print(result_lines(run, args.out))
    return 0


class _Executable(Protocol):
    def execute(self, on_batch: Callable[[int, int], None], checkpoint_interval: float) -> object: ...


class _Best(Protocol):
    @property
    def fitness(self) -> float | None: ...


class _OneObjective(_Executable, Protocol):
    """A composition or network run: one objective, its best so far, individuals produced."""

    produced: int

    @property
    def config(self) -> Any: ...

    @property
    def best(self) -> _Best | None: ...


def _execute_one(
    run: _OneObjective,
    write: Callable[[], object],
    objective: str,
    args: argparse.Namespace,
    argv: Sequence[str] | None,
    started: float,
    cluster: ClusterSettings,
) -> int | None:
    """:func:`_execute` of a composition or network run, its bar showing the best ``objective`` so far."""
    bar = progress_bar(run.config, run.produced, not args.no_progress)

    def on_batch(done: int, total: int) -> None:
        if bar is not None:
            bar.update(done - bar.n)
            if run.best is not None and run.best.fitness is not None:
                bar.set_postfix_str(f"{objective}={run.best.fitness:.3f}")

    return _execute(run, write, args, argv, started, cluster, bar, on_batch)


def _best_shown(run: _OneObjective) -> str:
    """The best fitness of a composition or network run as its last line shows it."""
    return "none" if run.best is None or run.best.fitness is None else f"{run.best.fitness:.4f}"


def _could_not_start(error: Exception, out: Path | None) -> int:
    """Say in one line why a run could not be started or continued; return the exit status."""
    if isinstance(error, WriteError):  # the new run directory could not be written
        print(f"evolve: error: {error}", file=sys.stderr)
        return EXIT_IO
    if isinstance(error, (UsageError, EvolutionError)):  # a ClusterError too: no scheduler, no SLURM
        print(f"evolve: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    assert isinstance(error, OSError)  # an --out that cannot be created or written, a planted link
    print(f"evolve: error: {describe(out or '--out', error)}", file=sys.stderr)
    return EXIT_USAGE


def _execute(
    run: _Executable,
    write: Callable[[], object],
    args: argparse.Namespace,
    argv: Sequence[str] | None,
    started: float,
    cluster: ClusterSettings,
    bar: tqdm | None,
    on_batch: Callable[[int, int], None],
) -> int | None:
    """Execute a started run with its progress bar, then ``write`` its results, the session recorded in
    the run directory before and after; None when it finished, else the exit status, its reason said in
    one line with how to continue."""
    # late, as the run's modules (see _evolve)
    from evolution_manager.studies.experiment import record_session

    command = "ws/run evolution_manager evolve " + " ".join(argv if argv is not None else sys.argv[1:])
    resume = f"continue with: evolve --out {args.out} --resume"
    try:  # Ctrl-C and SIGTERM raise here as anywhere in evolve (its signals_as_interrupts)
        record_session(args.out, started, command, cluster)
        run.execute(on_batch=on_batch, checkpoint_interval=args.checkpoint_every)
        if bar is not None:
            bar.close()
        write()
        record_session(args.out, started, command, cluster)
    except KeyboardInterrupt as interruption:  # Ctrl-C or SIGTERM: the last checkpoint holds the run
        if bar is not None:
            bar.close()
        print(f"evolve: interrupted; {resume}", file=sys.stderr)
        with contextlib.suppress(EvolutionError):  # the session's time, as far as it can be written
            record_session(args.out, started, command, cluster)
        return exit_status(interruption)
    except WriteError as error:  # a full disk: what was saved is whole (atomic files, logs cut on resume)
        if bar is not None:
            bar.close()
        remedy = "then" if isinstance(error.__cause__, UnsafePathError) else "make room, then"
        print(f"evolve: error: {error}; {remedy} {resume}", file=sys.stderr)
        return EXIT_IO
    except DispatchError as error:  # the cluster's workers could not finish a chunk
        if bar is not None:
            bar.close()
        print(f"evolve: error: {error}; {resume}", file=sys.stderr)
        return 1
    return None


def _compositions_asked(args: argparse.Namespace) -> bool:
    """Whether the command evolves compositions: ``--swarm-from`` or an algorithm only compositions have
    (``ga``, ``ascent``) given, or ``--resume`` of a composition run."""
    if args.swarm_from is not None or args.algorithm in set(COMPOSITION_ALGORITHMS) - set(ALGORITHMS):
        return True
    return bool(args.resume) and run_kind(args.out) == COMPOSITIONS


def _check_composition_options(args: argparse.Namespace, cluster: ClusterSettings) -> None:
    """Refuse the options a composition run has no use for, each in one line saying what was expected."""
    if not cluster.is_local:
        raise UsageError(
            "--cluster: compositions are evaluated here (--workers threads); leave --cluster out"
        )
    if args.library is not None and (args.swarm_from is not None or args.resume):
        raise UsageError(
            "--library cannot be combined with --swarm-from: a composition's cells are trees without one"
        )
    for name in ("objectives", "nodes"):
        if getattr(args, name) is not None:
            raise UsageError(
                f"--{name} applies to tree runs, not to compositions (--swarm-from); leave it out"
            )
    if args.resume:
        if args.swarm_from is not None:
            raise UsageError(
                "--swarm-from: the run's cells are read from its directory; leave it out with --resume"
            )
        return
    if args.swarm_from is None:
        raise UsageError(
            f"--algorithm {args.algorithm} evolves compositions of repertoire cells: give --swarm-from "
            "RUN_DIR [RUN_DIR ...] (and --task foraging)"
        )
    if args.task is None:
        raise UsageError(
            "--swarm-from evolves compositions on a task of foraging: add --task (foraging, "
            "multifood-arena9-kind2, ...)"
        )
    if args.algorithm not in COMPOSITION_ALGORITHMS:
        *others, last = COMPOSITION_ALGORITHMS
        raise UsageError(f"--swarm-from evolves compositions with --algorithm {', '.join(others)} or {last}")


def _check_homogeneous(algorithm: str, parameters: CompositionParameters, cells: int) -> None:
    """Refuse ``--homogeneous K`` with more seeds than the runs' cells or the initial population (ga) or
    batch (qd) hold, in one line (it was cut to the smaller silently)."""
    k = parameters.homogeneous
    initial, what = (
        (parameters.population, "population") if algorithm == "ga" else (parameters.init_batch, "batch")
    )
    if k > cells:
        raise UsageError(
            f"--homogeneous {k}: the runs hold {cells} cells, so there are only {cells} homogeneous swarms; "
            f"give K of at most {min(cells, initial)}"
        )
    if k > initial:
        raise UsageError(
            f"--homogeneous {k}: the initial {what} of --algorithm {algorithm} has {initial} genomes; give K "
            f"of at most {min(cells, initial)}"
        )


def _evolve_compositions(
    args: argparse.Namespace, argv: Sequence[str] | None, started: float, cluster: ClusterSettings
) -> int:
    """``evolve`` of compositions (``evolution.compositions``): start or continue a run, write its results."""
    from evolution_manager.evolution import compositions as comp  # late, as the run's modules in _evolve

    try:
        _check_composition_options(args, cluster)
        if args.resume:
            saved = comp.CompositionConfig.from_json(read_json_object(Path(args.out) / "config.json"))
            _check_as_saved(
                args,
                saved,
                (
                    "algorithm",
                    "evaluations",
                    "seed",
                    "trials",
                    "profile",
                    "scenario_seed",
                    "objective",
                    "scenarios",
                ),
            )
            if args.task is not None and args.task != saved.task:
                raise UsageError(
                    f"--task {args.task.name} differs from the run being resumed ({saved.task.name}); leave "
                    "it out or start a new run in another --out"
                )
            for name, option in {"homogeneous": "homogeneous", **_SWARM_OPTIONS}.items():
                value = getattr(args, option.replace("-", "_"))
                if value is not None and value != getattr(saved.parameters, name):
                    raise UsageError(
                        f"--{option} {value} differs from the run being resumed "
                        f"({getattr(saved.parameters, name)}); leave it out or start a new run in another "
                        "--out"
                    )
            if args.descriptors is not None and args.descriptors != saved.descriptors:
                raise UsageError(
                    f"--descriptors {args.descriptors} differs from the run being resumed "
                    f"({saved.descriptors}); leave it out or start a new run in another --out"
                )
            config = saved
            library = comp.CompositionDirectory(args.out).read_library(config)
        else:
            _refuse_a_started_run(args.out)
            comp.check_distinct_sources(args.swarm_from)
            cells, library = comp.read_sources(args.swarm_from)
            parameters = comp.CompositionParameters(
                homogeneous=args.homogeneous or 0,
                cell_mutation=args.swarm_mutation or "one",
                crossover_operator=args.swarm_crossover or "two-point",
                groups=args.swarm_groups or 0,
            )
            if args.algorithm != "ascent":  # whose configuration refuses seeds
                _check_homogeneous(args.algorithm, parameters, len(cells))
            config = comp.CompositionConfig(
                args.algorithm,
                args.evaluations or comp.DEFAULT_EVALUATIONS[args.algorithm],
                0 if args.seed is None else args.seed,
                args.trials or 10,
                args.profile or comp.DEFAULT_PROFILE,
                -1 if args.scenario_seed is None else args.scenario_seed,
                tuple(str(p) for p in args.swarm_from),
                len(cells),
                comp.cells_digest(cells),
                parameters,
                library_digest="" if library is None else library.digest,
                task=args.task,
                objective=args.objective or comp.OBJECTIVE,
                descriptors=args.descriptors or "behaviour",
                scenarios=args.scenarios or "fixed",
            )
        evaluator = _evaluator(args.workers, config, library)
        if args.resume:
            run = comp.CompositionRun.resume(args.out, evaluator)
        else:
            run = comp.CompositionRun.start(config, cells, args.out, evaluator, library)
    except (WriteError, UsageError, EvolutionError, OSError) as error:
        return _could_not_start(error, args.out)
    objective = run.config.objective
    failed = _execute_one(run, run.write_results, objective, args, argv, started, cluster)
    if failed is not None:
        return failed
    best = _best_shown(run)
    print(
        f"{run.config.label}: {run.evaluations} evaluations of compositions of {len(run.cells)} cells, best "
        f"{objective} {best}; the best swarm is {Path(args.out) / 'best' / f'{objective}_swarm.json'}"
    )
    return 0


def _check_as_saved(args: argparse.Namespace, saved: object, names: Sequence[str]) -> None:
    """Raise ``UsageError`` for an option of ``names`` given to ``--resume`` that differs from the saved
    configuration's field of that name."""
    for name in names:
        value = getattr(args, name)
        if value is not None and value != getattr(saved, name):
            raise UsageError(
                f"--{name.replace('_', '-')} {value} differs from the run being resumed "
                f"({getattr(saved, name)}); leave it out or start a new run in another --out"
            )


def _networks_asked(args: argparse.Namespace) -> bool:
    """Whether the command evolves a network's weights: ``--algorithm nn-*``, or ``--resume`` of such a
    run."""
    return args.algorithm in NETWORK_ALGORITHMS or (bool(args.resume) and run_kind(args.out) == NETWORKS)


def _evolve_networks(
    args: argparse.Namespace, argv: Sequence[str] | None, started: float, cluster: ClusterSettings
) -> int:
    """``evolve`` of a network's weights (``evolution.networks``): start or continue a run, write its
    summary and best network."""
    from evolution_manager.evolution import networks as nets  # late, as the run's modules in _evolve

    try:
        if not cluster.is_local:
            raise UsageError("--algorithm nn-cmaes, nn-ga and nn-qd run here only (--cluster local)")
        if args.library is not None or args.objectives is not None or args.scenarios not in (None, "fixed"):
            raise UsageError("network runs take no --library or --objectives, and fixed scenarios only")
        if args.resume:
            saved = nets.NetworkConfig.from_json(read_json_object(Path(args.out) / "config.json"))
            names = ("algorithm", "objective", "evaluations", "seed", "trials", "profile", "scenario_seed")
            _check_as_saved(args, saved, names)
            config = saved
        else:
            _refuse_a_started_run(args.out)
            if args.objective is None:
                raise UsageError(f"--algorithm {args.algorithm} needs --objective")
            task = "primitives" if args.task is None else registered_name(args.task)
            if task is None:
                raise UsageError("network runs take a registered --task (primitives or foraging)")
            config = nets.NetworkConfig(
                args.algorithm,
                args.objective,
                args.evaluations or 25_000,
                0 if args.seed is None else args.seed,
                args.trials or 10,
                args.profile or nets.DEFAULT_PROFILE,
                task,
                -1 if args.scenario_seed is None else args.scenario_seed,
            )
        evaluator = _evaluator(args.workers, config)
        if args.resume:
            run = nets.NetworkRun.resume(args.out, evaluator)
        else:
            run = nets.NetworkRun.start(config, args.out, evaluator)
    except (WriteError, UsageError, EvolutionError, OSError) as error:
        return _could_not_start(error, args.out)
    failed = _execute_one(run, run.finish, run.config.objective, args, argv, started, cluster)
    if failed is not None:
        return failed
    best = _best_shown(run)
    where = Path(args.out) / "best" / f"{run.config.objective}.json"
    print(f"{run.config.label}: {run.evaluations} evaluations, best {run.config.objective} {best}; {where}")
    return 0


def _teams_asked(args: argparse.Namespace) -> bool:
    """Whether the command evolves teams: ``--team K`` given, or ``--resume`` of a team run."""
    return args.team is not None or (bool(args.resume) and run_kind(args.out) == TEAMS)


def _check_team_options(args: argparse.Namespace, cluster: ClusterSettings) -> None:
    """Refuse the options a team run has no use for, each in one line saying what was expected."""
    if not cluster.is_local:
        raise UsageError("--team: teams are evaluated here (--workers threads); leave --cluster out")
    for name in ("swarm_from", "homogeneous", "library", "objectives", "nodes", "descriptors"):
        if getattr(args, name) is not None:
            raise UsageError(
                f"--{name.replace('_', '-')} does not apply to a team run (--team K: K trees evolved from "
                "scratch over the task's node set); leave it out"
            )
    if args.algorithm not in (None, "gp"):
        raise UsageError(f"--team K evolves K trees together with --algorithm gp, not {args.algorithm}")


def _start_trees(args: argparse.Namespace) -> tuple[str, ...]:
    """The tree texts the ``--start-tree`` options give (each the text, or the file it names), in order;
    ``UsageError`` for an empty one or a file that cannot be read."""
    texts = []
    for given in args.start_tree or ():
        try:
            text = tree_argument(given).strip()
        except ValueError as error:
            raise UsageError(f"--start-tree: {error}") from None
        if not text:
            raise UsageError("--start-tree: expected a tree (text, or a file holding it), got nothing")
        texts.append(text)
    return tuple(texts)


def _evolve_teams(
    args: argparse.Namespace, argv: Sequence[str] | None, started: float, cluster: ClusterSettings
) -> int:
    """``evolve --team K`` (``evolution.teams``): start or continue a team run, write its results."""
    from evolution_manager.evolution import teams  # late, as the run's modules in _evolve

    try:
        _check_team_options(args, cluster)
        if args.resume:
            saved = teams.TeamConfig.from_json(read_json_object(Path(args.out) / "config.json"))
            names = (
                "team",
                "objective",
                "evaluations",
                "seed",
                "trials",
                "profile",
                "scenario_seed",
                "scenarios",
            )
            _check_as_saved(args, saved, names)
            if args.task is not None and args.task != saved.task:
                raise UsageError(
                    f"--task {task_label(args.task)} differs from the run being resumed "
                    f"({task_label(saved.task)}); leave it out or start a new run in another --out"
                )
            if args.start_tree is not None and (
                replace(saved, start_trees=_start_trees(args)).start_trees != saved.start_trees
            ):
                raise UsageError(
                    "--start-tree differs from the run being resumed (its config.json: start_tree); leave it "
                    "out or start a new run in another --out"
                )
            config = saved
        else:
            _refuse_a_started_run(args.out)
            if args.algorithm is None:
                raise UsageError("--team K needs --algorithm gp")
            if args.objective is None:
                raise UsageError(f"--team needs --objective ({', '.join(OBJECTIVES)})")
            task = args.task or task_named("primitives")
            teams.check_team_size(args.team, task.config().n_robots, "--team")
            config = teams.TeamConfig.make(
                args.team,
                args.objective,
                args.evaluations,
                0 if args.seed is None else args.seed,
                args.trials or 10,
                args.profile,
                task,
                args.scenario_seed,
                args.scenarios or "fixed",
                _start_trees(args),
            )
        evaluator = _evaluator(args.workers, config)
        if args.resume:
            run = teams.TeamRun.resume(args.out, evaluator)
        else:
            run = teams.TeamRun.start(config, args.out, evaluator)
    except (WriteError, UsageError, EvolutionError, OSError) as error:
        return _could_not_start(error, args.out)
    failed = _execute_one(run, run.write_results, run.config.objective, args, argv, started, cluster)
    if failed is not None:
        return failed
    summary = read_json_object(Path(args.out) / "summary.json")
    held = summary["heldout_best_fitness"]
    where = Path(args.out) / "best" / f"{run.config.objective}_swarm.json"
    print(
        f"{run.config.label}: {run.evaluations} evaluations of teams of {run.config.team} trees, best "
        f"{run.config.objective} {_best_shown(run)}"
        + ("" if held is None else f" (held-out {held:.4f})")
        + f"; the best swarm is {where}"
    )
    return 0


def result_lines(run: object, out: Path) -> str:
    """What a finished run prints: evaluations, simulations saved, and per objective the in-run and
    held-out scores (from its summary.json)."""
    summary = read_json(Path(out) / "summary.json")
    assert isinstance(summary, dict)
    lines = [
        f"{summary['run']}: {summary['individuals_produced']} individuals produced, "
        f"{summary['evaluations']} evaluations, {summary['simulations']} simulated "
        f"({summary['simulations_saved']} answered from the fixed scenario's cache) in {out}"
    ]
    for objective, m in summary["objectives"].items():
        if not m["evolved"] or m["best_fitness"] is None:
            continue
        held = m["heldout_best_fitness"]
        held_qd = m["heldout_qd_score"]
        lines.append(
            f"{objective}: best {m['best_fitness']:.4f}"
            + (f" (held-out {held:.4f})" if held is not None else "")
            + f", coverage {m['coverage']:.4f}, QD score {m['qd_score']:.4f}"
            + (f" (held-out {held_qd:.4f})" if held_qd is not None else "")
            + f", {m['repertoire_size']} filled bins"
        )
    return "\n".join(lines)


def main() -> None:
    """Console entry point of ``evolve``."""
    sys.exit(evolve())


if __name__ == "__main__":
    main()
