"""The command-line options of a run, shared by ``evolve``, ``manager``, ``experiment`` and the main job:
the model's profile and scenarios, the run's configuration from the options, the check of a resume's options
against the saved run, and the progress bar."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from evolution_manager.arguments import seed_int
from evolution_manager.errors import EvolutionError, UsageError
from evolution_manager.evolution.run_config import OBJECTIVES, PROFILES, SCENARIOS, RunConfig

if TYPE_CHECKING:  # imported where used: tqdm loads slowly, and not every command needs it
    from tqdm import tqdm


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


def config_from_args(args: argparse.Namespace) -> RunConfig:
    if args.algorithm is None:
        raise UsageError("--algorithm is required to start a run (gp, gp-fnd or qd)")
    if args.algorithm != "gp-fnd" and args.objective is None:
        raise UsageError(f"--algorithm {args.algorithm} needs --objective ({', '.join(OBJECTIVES)})")
    if args.algorithm == "gp-fnd" and args.objective is not None:
        raise UsageError("--algorithm gp-fnd evolves all three objectives at once: leave out --objective")
    seed = 0 if args.seed is None else args.seed
    if args.scenario_seed is not None and args.scenarios == "fresh":
        raise UsageError("--scenario-seed applies to --scenarios fixed; leave it out with fresh")
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
        )
    except EvolutionError as error:
        raise UsageError(str(error).replace("the scenario seed", "--scenario-seed")) from None


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
    }
    for name, value in given.items():
        if value is not None and value != getattr(saved, name):
            raise UsageError(
                f"--{name.replace('_', '-')} {value} differs from the run being resumed "
                f"({getattr(saved, name)}); "
                "leave it out or start a new run in another --out"
            )


def progress_bar(config: RunConfig, initial: int, enabled: bool) -> tqdm | None:
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(
        total=config.evaluations,
        initial=initial,
        unit="eval",
        desc=config.label,
        dynamic_ncols=True,
        disable=None,
    )
