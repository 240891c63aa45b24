"""The command-line options of a run, shared by ``evolve``, ``manager``, ``experiment`` and the main job:
the model's profile and scenarios, the run's configuration from the options, the check of a resume's options
against the saved run, and the progress bar."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from bt_controller.draws import MAX_SEED
from bt_controller.language import Library, library_option
from evolution_manager.arguments import seed_int
from evolution_manager.errors import EvolutionError, UsageError
from evolution_manager.evolution.descriptor_sets import DESCRIPTOR_SETS
from evolution_manager.evolution.parameters import NODE_SETS
from evolution_manager.evolution.run_config import OBJECTIVES, PROFILES, SCENARIOS, RunConfig
from swarm_sim.tasks import add_task_option, task_label

if TYPE_CHECKING:  # every command's parser reads this module: tqdm and a run's modules load where used
    from tqdm import tqdm

    from evolution_manager.evolution.compositions import CompositionConfig
    from evolution_manager.evolution.networks import NetworkConfig


def add_scenario_options(parser: argparse.ArgumentParser) -> None:
    """``--profile paper|clean``, ``--scenarios fixed|fresh`` and ``--scenario-seed S``: the model and the
    scenarios a run is evaluated on (shared by evolve, manager, experiment and the main job)."""
    parser.add_argument(
        "--profile",
        choices=PROFILES,
        help=f"the model's profile (docs/model.md): {PROFILES[0]}, the authors' experiment (default), or "
        f"{PROFILES[1]}, without its artefacts; in config.json",
    )
    parser.add_argument(
        "--scenarios",
        choices=SCENARIOS,
        help="fixed: every evaluation on the run's scenario seed, repeats not simulated again (default); "
        "fresh: a new scenario per evaluation",
    )
    parser.add_argument(
        "--scenario-seed",
        type=seed_int,
        help="the scenario seed of fixed scenarios (default: derived from the run seed; in config.json)",
    )


def check_scenario_seed(args: argparse.Namespace) -> None:
    """Refuse a ``--scenario-seed`` outside [0, MAX_SEED] in one line (a negative one is not "derive it")."""
    value = getattr(args, "scenario_seed", None)
    if value is not None and not 0 <= value <= MAX_SEED:
        raise UsageError(f"--scenario-seed must be in [0, {MAX_SEED}], got {value}")


def add_task_options(parser: argparse.ArgumentParser) -> None:
    """``--task``, ``--objectives`` (GP_fnd's set), ``--library``, ``--nodes`` and ``--descriptors`` (evolve
    and manager)."""
    add_task_option(
        parser,
        default=None,
        what="; primitives: 20 s trials and the paper's node set (the default); foraging: the 2024 100 s "
        "foraging trials, with got_food in the node set",
    )
    parser.add_argument(
        "--objectives",
        help=f"gp-fnd: the objectives it evolves at once, comma-separated (of {', '.join(OBJECTIVES)}; "
        "default: density,nest,food for primitives, foraging for foraging)",
    )
    parser.add_argument(
        "--library",
        metavar="FILE",
        help="a primitive library (JSON): its primitives' names are leaves of the node set",
    )
    parser.add_argument(
        "--nodes",
        choices=NODE_SETS,
        help="the node set: hierarchical (the default with --library: composites, got_food, on_food, "
        "in_nest and the library's names, no actions) or flat (the default without: composites, the task's "
        "conditions, the actions, and the library's names if one is given)",
    )
    parser.add_argument(
        "--descriptors",
        choices=tuple(DESCRIPTOR_SETS),
        help="the behaviour space the grids bin trees by: "
        + "; ".join(f"{s.name}, {s.description}" for s in DESCRIPTOR_SETS.values())
        + " (default behaviour; deliveries needs a task with several kinds of food)",
    )


def library_from_args(args: argparse.Namespace) -> Library | None:
    """The library of ``--library`` (None without one); UsageError with its one line."""
    return library_option(getattr(args, "library", None), UsageError)


def config_from_args(args: argparse.Namespace) -> RunConfig:
    if args.algorithm is None:
        raise UsageError("--algorithm is required to start a run (gp, gp-fnd or qd)")
    if args.algorithm != "gp-fnd" and args.objective is None:
        raise UsageError(f"--algorithm {args.algorithm} needs --objective ({', '.join(OBJECTIVES)})")
    if args.algorithm == "gp-fnd" and args.objective is not None:
        raise UsageError("--algorithm gp-fnd evolves a set of objectives at once: leave out --objective")
    objectives_text = getattr(args, "objectives", None)
    if objectives_text is not None and args.algorithm != "gp-fnd":
        raise UsageError(f"--objectives is for gp-fnd; --algorithm {args.algorithm} takes --objective")
    fnd = tuple(o.strip() for o in objectives_text.split(",")) if objectives_text is not None else ()
    seed = 0 if args.seed is None else args.seed
    check_scenario_seed(args)
    if args.scenario_seed is not None and args.scenarios == "fresh":
        raise UsageError("--scenario-seed applies to --scenarios fixed; leave it out with fresh")
    library = library_from_args(args)
    try:
        return RunConfig.make(
            args.algorithm,
            args.objective,
            args.evaluations,
            seed,
            args.trials or 10,
            scenarios=args.scenarios or "fixed",
            scenario_seed=args.scenario_seed,
            profile=args.profile,
            task=getattr(args, "task", None) or "primitives",
            fnd_objectives=fnd,
            library=str(library.label) if library is not None else "",
            library_digest=library.digest if library is not None else "",
            nodes=getattr(args, "nodes", None),
            descriptors=getattr(args, "descriptors", None) or "behaviour",
        )
    except EvolutionError as error:
        message = str(error).replace("the scenario seed", "--scenario-seed")
        raise UsageError(message.replace("objectives must", "--objectives must")) from None


def check_resume_options(args: argparse.Namespace, saved: RunConfig) -> None:
    given = {
        "algorithm": args.algorithm,
        "objective": args.objective,
        "evaluations": args.evaluations,
        "seed": args.seed,
        "trials": args.trials,
        "scenarios": getattr(args, "scenarios", None),
        "scenario_seed": getattr(args, "scenario_seed", None),
        "profile": getattr(args, "profile", None),
        "task": getattr(args, "task", None),
        "nodes": getattr(args, "nodes", None),
        "descriptors": getattr(args, "descriptors", None),
    }
    if getattr(args, "objectives", None) is not None or getattr(args, "library", None) is not None:
        raise UsageError(
            "--objectives and --library are the run's, read from its directory: leave them out with --resume"
        )
    for name, value in given.items():
        if value is not None and value != getattr(saved, name):
            shown, kept = (
                (task_label(value), task_label(saved.task))
                if name == "task"
                else (value, getattr(saved, name))
            )
            raise UsageError(
                f"--{name.replace('_', '-')} {shown} differs from the run being resumed ({kept}); "
                "leave it out or start a new run in another --out"
            )


def progress_bar(
    config: RunConfig | CompositionConfig | NetworkConfig, initial: int, enabled: bool
) -> tqdm | None:
    if not enabled:
        return None
    from tqdm import tqdm  # late: about 70 ms, only when a bar is shown

    return tqdm(
        total=config.evaluations,
        initial=initial,
        unit="eval",
        desc=config.label,
        dynamic_ncols=True,
        disable=None,
    )
