"""Planning a study: which runs an experiment makes, in which stages, and whether a saved plan may grow.

``plan`` lists the 2023 paper's runs (every algorithm x objective x run, each with its seed and folder) and
``paper_study`` makes its plan document; the foraging, replication and ablation studies plan theirs in their
own modules with ``shared_scenario_seed`` and ``Stage``. ``more_runs`` says whether a new plan only adds
runs to a saved one (``experiment --runs N`` grows an experiment), ``differences`` what else differs, for a
message.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Protocol

from bt_controller.draws import RUN_EXPERIMENT, RUN_SCENARIO, derive_seed
from evolution_manager.errors import EvolutionError, UsageError
from evolution_manager.evolution.run_config import ALGORITHMS, RunConfig
from evolution_manager.files import read_json
from swarm_sim.model import PAPER_OBJECTIVES

PLAN_FILE = "experiment.json"
STUDIES = ("paper", "foraging", "replication", "ablation", "bt-vs-nn", "heterogeneity", "qd-schedule")
DESIGNS = ("shared", "per-run")
"""Under fixed scenarios: every run on one scenario (the authors' design), or each run on its own."""


def shared_scenario_seed(seed: int) -> int:
    """The scenario seed every run of an experiment of seed ``seed`` shares under the ``shared`` design."""
    return derive_seed(seed, RUN_SCENARIO)


def plan(
    runs: int,
    evaluations: int,
    seed: int,
    trials: int = 10,
    scenarios: str = "fixed",
    scenario_seed: int | None = None,
    profile: str | None = None,
    design: str = "shared",
) -> list[tuple[RunConfig, str]]:
    """Every run of the experiment with its directory relative to the experiment's folder. ``design``
    (``DESIGNS``) says whether the runs share one scenario (``scenario_seed``, or derived from ``seed``)."""
    if design not in DESIGNS:
        raise UsageError(f"--design must be one of {', '.join(DESIGNS)}, got {design!r}")
    if design == "per-run" and scenario_seed is not None:
        raise UsageError("--scenario-seed gives every run the same scenario: that is --design shared")
    if design == "shared" and scenarios == "fixed" and scenario_seed is None:
        scenario_seed = shared_scenario_seed(seed)
    planned = []
    for a, algorithm in enumerate(ALGORITHMS):
        objectives: Sequence[str | None] = [None] if algorithm == "gp-fnd" else PAPER_OBJECTIVES
        budget = 3 * evaluations if algorithm == "gp-fnd" else evaluations
        for objective in objectives:
            o = -1 if objective is None else PAPER_OBJECTIVES.index(objective)
            for r in range(runs):
                run_seed = derive_seed(seed, RUN_EXPERIMENT, a, o + 1, r)
                config = RunConfig.make(
                    algorithm, objective, budget, run_seed, trials, scenarios, scenario_seed, profile
                )
                planned.append((config, f"runs/{config.label}/run{r:02d}"))
    return planned


class Planned(Protocol):
    """What a stage plans: a tree run's ``RunConfig`` or a composition run's ``CompositionConfig``."""

    @property
    def evaluations(self) -> int: ...

    def to_json(self) -> dict: ...


Stage = Callable[[], Sequence[tuple[Planned, str]]]
"""A stage of a study: called when the stages before it have finished, it gives the runs to run (each with
its directory relative to the study's folder)."""


def more_runs(saved: object, given: object) -> bool:
    """Whether the plan document ``given`` only adds runs to ``saved``: more runs per group, or (a study
    that lists its arms) more arms, every other option the same, and every run ``saved`` planned planned
    again with the same folder and configuration (run seeds are derived from the run's index, so raising
    ``--runs`` keeps the first runs as they were; an arm's runs never change another's)."""
    if not (isinstance(saved, dict) and isinstance(given, dict)) or saved.keys() != given.keys():
        return False
    if any(saved[key] != given[key] for key in saved if key not in ("runs", "plan", "arms")):
        return False
    old_runs, new_runs = saved.get("runs"), given.get("runs")
    old_arms, new_arms = saved.get("arms", []), given.get("arms", [])
    old_plan, new_plan = saved.get("plan"), given.get("plan")
    if not (isinstance(old_runs, int) and isinstance(new_runs, int) and new_runs >= old_runs):
        return False
    if not (isinstance(old_arms, list) and isinstance(new_arms, list) and set(old_arms) <= set(new_arms)):
        return False
    if new_runs == old_runs and len(new_arms) == len(old_arms):
        return False
    if not (isinstance(old_plan, list) and isinstance(new_plan, list)):
        return False
    planned = {json.dumps(entry, sort_keys=True) for entry in new_plan}
    return all(json.dumps(entry, sort_keys=True) in planned for entry in old_plan)


def growth(saved: object, given: object) -> str:
    """How a plan ``more_runs`` accepts grows, for the message: more runs per group, new arms, or both."""
    assert isinstance(saved, dict) and isinstance(given, dict)  # what more_runs accepted
    parts = []
    if given["runs"] > saved["runs"]:
        parts.append(f"to {given['runs']} runs per group")
    added = [arm for arm in given.get("arms", []) if arm not in saved.get("arms", [])]
    if added:
        parts.append(f"by the arm{'s' if len(added) > 1 else ''} {', '.join(added)}")
    return " and ".join(parts)


def differences(saved: object, given: object, shown: int = 3) -> str:
    """What differs between an experiment's saved plan document and the one the options make, for a
    message: the options first (``evaluations 150 there, 300 given``), the planned runs only when no option
    differs; at most ``shown`` of them, then how many more."""
    found: list[tuple[str, str]] = []
    _differ(saved, given, "", found)
    options = [text for where, text in found if not any(c in where for c in ".[")]
    listed = options or [text for _, text in found] or ["the documents differ"]
    more = f" and {len(listed) - shown} more" if len(listed) > shown else ""
    return "; ".join(listed[:shown]) + more


def _differ(saved: object, given: object, where: str, found: list[tuple[str, str]]) -> None:
    if isinstance(saved, dict) and isinstance(given, dict):
        for key in [*given, *(k for k in saved if k not in given)]:
            name = f"{where}.{key}" if where else str(key)
            if key not in saved:
                found.append((name, f"{name} absent there, {_shown(given[key])} given"))
            elif key not in given:
                found.append((name, f"{name} {_shown(saved[key])} there, absent now"))
            else:
                _differ(saved[key], given[key], name, found)
    elif isinstance(saved, list) and isinstance(given, list) and len(saved) == len(given):
        for i, (a, b) in enumerate(zip(saved, given, strict=True)):
            _differ(a, b, f"{where}[{i}]", found)
    elif isinstance(saved, list) and isinstance(given, list):
        found.append((where, f"{where}: {len(saved)} entries there, {len(given)} given"))
    elif saved != given:
        found.append((where, f"{where} {_shown(saved)} there, {_shown(given)} given"))


def _shown(value: object, width: int = 40) -> str:
    text = json.dumps(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def document_head(
    args: argparse.Namespace, profile: str, scenarios: str, design: str | None, scenario_seed: int | None
) -> dict:
    """The options a study's plan document records first, in this order: the profile, ``--runs``,
    ``--evaluations``, ``--seed``, ``--trials``, the scenarios, the design and the shared scenario seed."""
    return {
        "profile": profile,
        "runs": args.runs,
        "evaluations": args.evaluations,
        "seed": args.seed,
        "trials": args.trials,
        "scenarios": scenarios,
        "design": design,
        "scenario_seed": scenario_seed,
    }


def paper_study(
    args: argparse.Namespace, scenarios: str, design: str | None
) -> tuple[dict, list[Stage], dict[str, int]]:
    """The 2023 paper's experiment: its plan document, its one stage, the budget of every run."""
    planned = plan(
        args.runs,
        args.evaluations,
        args.seed,
        args.trials,
        scenarios,
        args.scenario_seed,
        args.profile,
        design or "per-run",
    )
    shared = {config.scenario_seed for config, _ in planned}
    scenario_seed = shared.pop() if design == "shared" else args.scenario_seed
    document = {
        **document_head(args, planned[0][0].profile, scenarios, design, scenario_seed),
        "plan": [{"dir": path, "config": config.to_json()} for config, path in planned],
    }
    return document, [lambda: planned], {path: config.evaluations for config, path in planned}


def foraging_study_plan(source: Path) -> dict:
    """The plan document of the foraging study in ``source`` (a study's ``--primitives-from``); UsageError
    in one line when the folder holds another kind of experiment."""
    document = read_json(Path(source) / PLAN_FILE)
    if not isinstance(document, dict) or document.get("study") != "foraging":
        raise UsageError(f"--primitives-from {source} is not a foraging study folder ({PLAN_FILE})")
    return document


def primitives_study_document(
    study: str,
    source_folder: Path,
    source: dict,
    args: argparse.Namespace,
    scenarios: str,
    scenario_seed: int | None,
    libraries: dict,
    runs_key: str,
    runs: list[dict],
) -> tuple[dict, dict[str, int]]:
    """The plan document of a study over a foraging study's primitives (``--primitives-from``): the study,
    its source, the source's profile, trials and design, the options, the libraries and last, under
    ``runs_key``, its ``runs`` (plan entries, each with its ``dir`` and ``evaluations``); and each run's
    budget by its folder."""
    document = {
        "study": study,
        "primitives_from": str(source_folder),
        "profile": source["profile"],
        "runs": args.runs,
        "evaluations": args.evaluations,
        "seed": args.seed,
        "trials": source["trials"],
        "scenarios": scenarios,
        "design": source["design"],
        "scenario_seed": scenario_seed,
        "libraries": libraries,
        runs_key: runs,
    }
    return document, {str(entry["dir"]): int(entry["evaluations"]) for entry in runs}


def primitives_study_forager(
    entry: dict,
    algorithm: str,
    source: dict,
    scenarios: str,
    scenario_seed: int | None,
    library: str,
    library_digest: str,
) -> tuple[RunConfig, str]:
    """The foraging run of a plan entry of a study over a foraging study's primitives (its budget, seed and
    folder) with ``algorithm`` on the library ``library`` (of ``library_digest``), at the trials and profile
    of the ``source`` study and the study's scenarios; and the run's folder in the study."""
    made = RunConfig.make(
        algorithm,
        "foraging",
        int(entry["evaluations"]),
        int(entry["seed"]),
        source["trials"],
        scenarios,
        scenario_seed,
        source["profile"],
        task="foraging",
        library=library,
        library_digest=library_digest,
    )
    return made, str(entry["dir"])


def finished_foraging_runs(
    root: Path, study: str, runs_key: str
) -> Iterator[tuple[dict, float, float | None]]:
    """The finished runs of the ``study`` planned in ``root``'s ``experiment.json`` under ``runs_key``, in
    the plan's order: each plan entry with its best and held-out best foraging fitness (None when not
    measured). ``EvolutionError`` when ``root`` holds another study."""
    document = read_json(Path(root) / "experiment.json")
    if not isinstance(document, dict) or document.get("study") != study:
        article = "an" if study[0] in "aeiou" else "a"
        raise EvolutionError(f"{root} is not {article} {study} study (experiment.json)")
    for entry in document[runs_key]:
        summary_path = Path(root) / entry["dir"] / "summary.json"
        summary = read_json(summary_path) if summary_path.exists() else None
        if not isinstance(summary, dict) or not summary.get("finished"):
            continue
        scores = summary["objectives"]["foraging"]
        held = scores.get("heldout_best_fitness")
        yield entry, float(scores["best_fitness"]), None if held is None else float(held)
