"""``experiment --study heterogeneity``: when does a heterogeneous swarm beat the best homogeneous one?
(issue 36)

    ws/run evolution_manager experiment --study heterogeneity --runs 10 --evaluations 10000 \\
        --swarm-evaluations 2000 [--tasks T1,T2] --out experiments/heterogeneity

For every task of :data:`TASKS` that ``--tasks`` names (by default :data:`DEFAULT_TASKS`), with its objective
and behaviour space, and every run ``r``:

1. **A repertoire** (``repertoires/<task>/run<r>``): MAP-Elites over trees on the task, binned by the
   deliveries of each food kind (``--descriptors deliveries``; on a task of one kind, by the paper's
   behaviour), ``--evaluations`` trees.
2. **The arms** (``arms/<task>/<arm>/run<r>``, :data:`ARMS`): compositions of that repertoire's cells, one per
   robot (``evolution.compositions``), ``--swarm-evaluations`` genomes each: "generate, then allocate"; and
   the teams (``evolution.teams``): K trees evolved together by GP with no repertoire, robot i running tree
   i mod K, for K = 2, 3 and 9, with ``--evaluations`` plus ``--swarm-evaluations`` teams each, the whole
   budget of a repertoire and a composition run (equal evaluations, and so equal simulated time).

Every run of task ``t`` and index ``r``, the repertoire and each arm, has the seed ``derive_seed(--seed,
RUN_STUDY, HETEROGENEITY_STAGE, t, r)``, so the arms pair by seed, and composes from the same repertoire. The
**homogeneous** baseline is measured by each composition run itself (``summary.json``, ``homogeneous``): the
best of its cells' nine copies on the run's scenario, re-scored on the held-out scenarios; the study reads it
from the run of the first arm. Every run is evaluated on fixed scenarios, but for the arms ``ga-fresh``,
``qd-fresh`` and ``team<K>-fresh``, whose every evaluation has a scenario of its own (``--scenarios
fresh``); under the ``shared``
design (the default) on one scenario seed for the whole study, otherwise each on its seed's own, which the
repertoire and the arms of one index share (with their held-out, validation and baseline scenarios). Arms
added to the study later grow its plan (``planning.more_runs``): the runs planned before keep their folders.

The stages go task by task: the repertoires, the compositions, then the teams (the longest runs, needing no
repertoire), so that each task's table fills before the next task's runs begin. The report (``report.md``,
``runs.csv``, ``figures/``), regenerated from the finished runs in the plan's order, has per task and arm
the held-out median with its 95 % bootstrap interval, the ratio to the homogeneous median, paired tests of
each arm against the homogeneous baseline (``compare_paired``: Shapiro-Wilk on the differences, then a
paired t-test or Wilcoxon signed-rank) with Holm's correction over the family of every arm on every task,
the authors' QD score at 1, 2, 4 and 8 bins per axis of every composition run, and each robot's deliveries
of each kind in the best swarms. Two more tables with their own families: the runs' validated choices
(``evolution.validation``), and the same choices on arenas no run evolved on (the task's ``-unseen`` twin,
``swarm_sim.tasks.unseen_twin``, on the run's held-out seeds; measured once into ``unseen.csv``). An arm with
a twin (``Arm.twin``: the team evolved from a start tree and the same GP over one tree from that start) is
also paired with it, in a table and family of its own. On a task
of three food kinds, the hand-written swarms of ``division-bench`` on the same held-out scenarios, paired
with the baseline (``handwritten_swarms``; measured once into ``handwritten.csv``).
"""

from __future__ import annotations

import argparse
import csv
import io
import itertools
import math
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bt_controller.draws import RUN_STUDY, derive_seed
from evolution_manager.errors import EvolutionError, UsageError
from evolution_manager.evolution.archive import GRID_SHAPE
from evolution_manager.evolution.compositions import (
    QD_SCORE_BINS,
    CompositionConfig,
    CompositionParameters,
    read_sources,
)
from evolution_manager.evolution.descriptor_sets import DELIVERY_SETS, descriptor_set
from evolution_manager.evolution.run_config import DEFAULT_PROFILE, RunConfig
from evolution_manager.evolution.teams import TeamConfig
from evolution_manager.files import read_json, write_atomic
from evolution_manager.studies.handwritten_swarms import (
    HETEROGENEOUS,
    KIND_COLUMNS,
    handwritten_scores,
)
from evolution_manager.studies.intervals import interval
from evolution_manager.studies.planning import PLAN_FILE, Stage, document_head, shared_scenario_seed
from evolution_manager.studies.significance import Comparison, compare_paired, holm, markdown_table
from swarm_sim.bench.division import KINDS, any_forager, kind_forager
from swarm_sim.evaluation import BatchEvaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, Config, SwarmLayout
from swarm_sim.tasks import TaskError, task_named, unseen_twin

STUDY = "heterogeneity"
HETEROGENEITY_STAGE = 7
"""The stage index of this study's seeds (foraging 0 to 3, replication 4, ablation 5, bt-vs-nn 6)."""
DEFAULT_SWARM_EVALUATIONS = 2000

TASKS: tuple[tuple[str, str, str], ...] = (
    ("multifood-arena9-kind2", "foraging_biased", "deliveries"),
    ("multifood-arena6", "foraging", "deliveries"),
    ("multifood-arena7-types", "foraging", "behaviour"),
    ("multifood-arena6-balanced", "foraging_balanced", "deliveries"),
    ("multifood-arena6-carriers", "foraging", "deliveries"),
)
"""The tasks, each with the objective its runs maximise and the behaviour space its repertoires and
compositions are binned by: the authors' arena 9 biased towards kind 2 (their bias and penalty fitness,
penalty 0.5); arena 6, three kinds of food and no bias; arena 7 with their two robot types (odd robots
perceive the nest and the food swapped), every robot starting at its own food: one kind of food, so binned by
the paper's behaviour; arena 6 scored by the swarm's least delivered kind (``foraging_balanced``, issue
36), meant as a task where a division of labour could pay (hand-written specialists do not:
``docs/results/heterogeneity/balanced``); and arena 6 in trials of 300 s where robot i can pick up only food
kind i mod 3 + 1 (``robots.carries``), maximising the deliveries of every kind (``foraging``), where
hand-written specialists do beat the best homogeneous swarm (``docs/results/heterogeneity/carriers``); its
groups are those of ``team3`` (robot i runs tree i mod K). A task's seeds derive from its index here,
whichever are planned."""
DEFAULT_TASKS: tuple[str, ...] = tuple(task for task, _, _ in TASKS[:3])
"""The tasks planned when ``--tasks`` is not given: the study's first three, whose plan (``experiment.json``)
is the one studies begun before the fourth and fifth keep."""

BASELINE = "homogeneous"
GOAL = 1.2
"""The issue's goal: a heterogeneous arm's held-out median at least this many times the baseline's."""


@dataclass(frozen=True)
class Arm:
    """A way of composing swarms from a repertoire."""

    name: str
    algorithm: str
    what: str
    homogeneous: int = 0
    cell_mutation: str = "one"
    crossover_operator: str = "two-point"
    team: int = 0
    """K, for a team arm (``evolution.teams``); 0 for a composition arm."""
    scenarios: str = "fixed"
    """The arm's evaluations: on the study's scenario (``fixed``) or each on its own (``fresh``)."""
    groups: int = 0
    """K, for a composition arm of K groups of robots, one cell each (``CompositionParameters.groups``)."""
    start_trees: tuple[str, ...] = ()
    """For a team arm: the tree every sub-group of its first teams runs, or one per sub-group
    (``TeamConfig.start_trees``); empty: random trees."""
    twin: str = ""
    """The arm this one is also paired with: the same search over one tree from the same start, so that the
    report can tell what evolving several trees adds from what the start gives."""

    @property
    def parameters(self) -> CompositionParameters:
        return CompositionParameters(
            homogeneous=self.homogeneous,
            cell_mutation=self.cell_mutation,
            crossover_operator=self.crossover_operator,
            groups=self.groups,
        )


ANY_FORAGER = any_forager()
"""The start tree of ``team3-any-fresh`` and of its twin: one text, so that the two start alike."""
SPECIALIST_FORAGERS = tuple(kind_forager(kind) for kind in KINDS)
"""The start trees of ``team3-specialists-fresh``: group g the hand-written forager of kind g + 1 only, the
kind its robots carry on ``multifood-arena6-carriers`` (``division-bench``'s hand-written specialists)."""
ARMS: tuple[Arm, ...] = (
    Arm("ga", "ga", "the GA over compositions, all random at first (the authors' GA)"),
    Arm("ga-seeded", "ga", "the GA seeded with the homogeneous swarms of the 5 fittest cells", homogeneous=5),
    Arm("qd", "qd", "the authors' MAP-Elites over compositions binned by deliveries (two-point crossover)"),
    Arm("qd-mix", "qd", "MAP-Elites over compositions with Mix-ME's mixing", crossover_operator="mix"),
    Arm("ga-fresh", "ga", "the authors' GA with every evaluation on a scenario of its own (fresh scenarios)",
        scenarios="fresh"),
    Arm("qd-fresh", "qd", "the authors' MAP-Elites with every evaluation on a scenario of its own",
        scenarios="fresh"),
    *(
        Arm(f"team{k}", "gp", f"GP over {k} trees evolved together, no repertoire (robot i runs tree i "
            f"mod {k})", team=k)
        for k in (2, 3, 9)
    ),
    *(
        Arm(f"team{k}-fresh", "gp", f"GP over {k} trees evolved together with every evaluation on a scenario "
            "of its own", team=k, scenarios="fresh")
        for k in (2, 3, 9)
    ),
    Arm("ga-groups3", "ga", "the authors' GA over 3 cells, robot i running cell i mod 3 (the groups of team3 "
        "and of robots.carries)", groups=3),
    Arm("qd-groups3", "qd", "the authors' MAP-Elites over 3 cells, robot i running cell i mod 3", groups=3),
    Arm("ascent-groups3", "ascent", "coordinate ascent over 3 cells from the best homogeneous swarm: each "
        "group's cell in turn set to its best response to the others'", groups=3),
    Arm("team3-any-fresh", "gp", "GP over 3 trees, each group starting from the hand-written forager of "
        "any kind, every evaluation on a scenario of its own", team=3, scenarios="fresh",
        start_trees=(ANY_FORAGER,), twin="homogeneous-any-fresh"),
    Arm("homogeneous-any-fresh", "gp", "GP over one tree from the same hand-written forager, every "
        "evaluation on a scenario of its own: team3-any-fresh's homogeneous twin", team=1, scenarios="fresh",
        start_trees=(ANY_FORAGER,)),
    Arm("team3-specialists-fresh", "gp", "GP over 3 trees, group g starting from the hand-written forager of "
        "kind g + 1 only (the kind its robots carry on the carriers task), every evaluation on a scenario of "
        "its own", team=3, scenarios="fresh", start_trees=SPECIALIST_FORAGERS),
)  # fmt: skip
DEFAULT_ARMS: tuple[str, ...] = tuple(arm.name for arm in ARMS[:12])
"""The arms planned when ``--arms`` is not given: the study's first twelve, whose plan the studies begun
before the group compositions keep."""
HEADER = [
    "arm", "task", "seed", "best_fitness", "heldout_best_fitness",
    "heldout_foraging1", "heldout_foraging2", "heldout_foraging3",
    *(f"qd_score_{k}" for k in QD_SCORE_BINS), "validated_heldout_best_fitness", "unseen_heldout_fitness",
]  # fmt: skip
"""``runs.csv``: one row per run; the QD scores (of every genome the run evaluated) are empty for the
baseline; the validated choice's held-out score (``evolution.validation``) is empty for runs made before
it; the validated choice's score on unseen arenas is empty where the task has none."""

HELDOUT = "heldout_best_fitness"
VALIDATED = "validated_heldout_best_fitness"
UNSEEN = "unseen_heldout_fitness"
"""The three held-out scores the report compares arms by: of the run's best on its scenario, of its
validated choice, and of that choice on the task's unseen arenas (``swarm_sim.tasks.unseen_twin``)."""
METRICS = {
    HELDOUT: "held-out best fitness",
    VALIDATED: "validated held-out fitness",
    UNSEEN: "unseen-arena held-out fitness",
}
UNSEEN_FILE = "unseen.csv"
UNSEEN_HEADER = ["dir", "swarm", "seeds", "trials", "fitness"]
"""The study folder's record of every score on unseen arenas (a run's folder, ``validated`` or the
baseline's ``homogeneous``, the held-out seeds and trials): measured once, read back by every report."""
MEMBERS_FILE = "members.csv"
MEMBERS_HEADER = ["dir", "swarm", "group", "seeds", "trials", "fitness"]
"""``members.csv``: each tree of a heterogeneous team's best and validated swarms run by every robot, on the
run's held-out scenarios (:func:`member_scores`)."""


def _folder(kind: str, task: str, r: int) -> str:
    return f"{kind}/{task}/run{r:02d}"


def _named(text: str, names: Sequence[str], what: str) -> set[str]:
    """The names a comma-separated option (``--tasks``, ``--arms``: ``what`` is ``task`` or ``arm``) gives;
    ``UsageError`` in one line listing ``names`` for an unknown one or none."""
    given = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in given if name not in names]
    if unknown or not given:
        problem = f"unknown {what} {unknown[0]!r}" if unknown else f"no {what} in {text!r}"
        raise UsageError(f"--{what}s: {problem}; expected some of {','.join(names)}")
    return set(given)


def chosen_tasks(text: str | None) -> list[int]:
    """The indices in :data:`TASKS` of the tasks ``--tasks`` names (comma-separated; in ``TASKS`` order),
    those of :data:`DEFAULT_TASKS` when None; ``UsageError`` in one line listing the choices for an unknown
    one."""
    names = [task for task, _, _ in TASKS]
    given = set(DEFAULT_TASKS) if text is None else _named(text, names, "task")
    return [t for t, name in enumerate(names) if name in given]


def chosen_arms(text: str | None) -> list[Arm]:
    """The arms of :data:`ARMS` that ``--arms`` names (comma-separated; in ``ARMS`` order), those of
    :data:`DEFAULT_ARMS` when None; ``UsageError`` in one line listing the choices for an unknown one. The
    homogeneous baseline comes with every composition arm; a plan of team arms only has none."""
    if text is None:
        return [arm for arm in ARMS if arm.name in DEFAULT_ARMS]
    given = _named(text, [arm.name for arm in ARMS], "arm")
    return [arm for arm in ARMS if arm.name in given]


def plan_study(
    args: argparse.Namespace, scenarios: str, design: str | None
) -> tuple[dict, list[Stage], dict[str, int]]:
    """The study's plan document, its stages and the budget of every run, from the command line."""
    if scenarios != "fixed":
        raise UsageError("--study heterogeneity runs under fixed scenarios only (compositions know no other)")
    swarm_evaluations = args.swarm_evaluations or DEFAULT_SWARM_EVALUATIONS
    profile = args.profile or DEFAULT_PROFILE
    scenario_seed = args.scenario_seed
    if design == "shared" and scenario_seed is None:
        scenario_seed = shared_scenario_seed(args.seed)
    out = Path(args.out).absolute()
    chosen = chosen_tasks(args.tasks)
    planned_arms = chosen_arms(args.arms)
    # --descriptors: one behaviour space for every task's repertoires and compositions instead of its own
    tasks = [(TASKS[t][0], TASKS[t][1], args.descriptors or TASKS[t][2]) for t in chosen]
    if not any(not arm.team for arm in planned_arms):
        raise UsageError("--arms: a plan needs a composition arm (its runs measure the homogeneous baseline)")
    entries: list[dict] = []
    stages: list[Stage] = []
    budgets: dict[str, int] = {}
    for t, (task, objective, descriptors) in zip(chosen, tasks, strict=True):
        repertoires: list[tuple[RunConfig | TeamConfig, str]] = []
        for r in range(args.runs):
            seed = derive_seed(args.seed, RUN_STUDY, HETEROGENEITY_STAGE, t, r)
            made = RunConfig.make(
                "qd", objective, args.evaluations, seed, args.trials, "fixed", scenario_seed, profile,
                task=task, descriptors=descriptors,
            )  # fmt: skip
            folder = _folder("repertoires", task, r)
            repertoires.append((made, folder))
            entries.append({"kind": "repertoire", "task": task, "dir": folder, "config": made.to_json()})
            budgets[folder] = made.evaluations
        arms: list[dict] = []
        teams: list[tuple[RunConfig | TeamConfig, str]] = []
        for arm in (a for a in planned_arms if a.team):
            for r in range(args.runs):
                seed = derive_seed(args.seed, RUN_STUDY, HETEROGENEITY_STAGE, t, r)
                team = TeamConfig.make(
                    arm.team, objective, args.evaluations + swarm_evaluations, seed, args.trials, profile,
                    task, scenario_seed, arm.scenarios, arm.start_trees,
                )  # fmt: skip
                folder = f"arms/{task}/{arm.name}/run{r:02d}"
                entries.append({"kind": "team", "arm": arm.name, "task": task, "dir": folder,
                                "seed": seed, "config": team.to_json()})  # fmt: skip
                teams.append((team, folder))
                budgets[folder] = team.evaluations
        for arm in (a for a in planned_arms if not a.team):
            for r in range(args.runs):
                folder = f"arms/{task}/{arm.name}/run{r:02d}"
                entry: dict[str, object] = {
                    "kind": "composition",
                    "arm": arm.name,
                    "task": task,
                    "objective": objective,
                    "descriptors": descriptors,
                    "dir": folder,
                    "from": _folder("repertoires", task, r),
                    "seed": derive_seed(args.seed, RUN_STUDY, HETEROGENEITY_STAGE, t, r),
                    "evaluations": swarm_evaluations,
                }
                if arm.scenarios != "fixed":  # only then: the entries of the first arms stay as planned
                    entry["scenarios"] = arm.scenarios
                arms.append(entry)
                entries.append(entry)
                budgets[folder] = swarm_evaluations
        stages.append(_given(repertoires))
        stages.append(_composed(out, arms, args.trials, profile, scenario_seed))
        stages.append(_given(teams))  # they need no repertoire; last, so that the compositions report first
    document = {
        "study": STUDY,
        **document_head(args, profile, scenarios, design, scenario_seed),
        "swarm_evaluations": swarm_evaluations,
        "tasks": [{"task": t, "objective": o, "descriptors": d} for t, o, d in tasks],
        "arms": [arm.name for arm in planned_arms],
        "plan": entries,
    }
    return document, stages, budgets


def _given(planned: list[tuple[RunConfig | TeamConfig, str]]) -> Stage:
    """A stage of runs known when the study is planned."""
    return lambda: planned


def _composed(out: Path, arms: Sequence[dict], trials: int, profile: str, scenario_seed: int | None) -> Stage:
    """The stage of one task's composition runs: made when it starts, from its finished repertoires."""
    return lambda: _compositions(out, arms, trials, profile, scenario_seed)


def _compositions(
    out: Path, arms: Sequence[dict], trials: int, profile: str, scenario_seed: int | None
) -> list[tuple[CompositionConfig, str]]:
    """The composition runs of one task, made once its repertoires have finished (their cells)."""
    from evolution_manager.evolution import compositions as comp  # late: reads the source runs' files

    by_name = {arm.name: arm for arm in ARMS}
    planned = []
    for entry in arms:
        source = out / entry["from"]
        cells, library = comp.read_sources([source])
        made = comp.CompositionConfig(
            by_name[entry["arm"]].algorithm,
            entry["evaluations"],
            entry["seed"],
            trials,
            profile,
            -1 if scenario_seed is None else scenario_seed,
            (str(source),),
            len(cells),
            comp.cells_digest(cells),
            by_name[entry["arm"]].parameters,
            library_digest="" if library is None else library.digest,
            task=entry["task"],
            objective=entry["objective"],
            descriptors=entry["descriptors"],
            scenarios=str(entry.get("scenarios", "fixed")),
        )
        planned.append((made, entry["dir"]))
    return planned


# Reading the runs -----------------------------------------------------------------------------------------
def _number(value: object) -> str:
    return "" if value is None else repr(float(value))  # type: ignore[arg-type]  # a JSON number


def _summary(root: Path, folder: str) -> dict | None:
    path = root / folder / "summary.json"
    summary = read_json(path) if path.exists() else None
    if isinstance(summary, dict) and summary.get("finished") and summary.get("heldout") is not None:
        return summary
    return None


def _validated(choice: object) -> str:
    """The held-out score of a validated choice (``summary.json``'s ``validated``), empty without one."""
    return _number(choice.get("heldout_best_fitness")) if isinstance(choice, dict) else ""


def _kinds(entry: dict, fitness: object, values: object) -> list[str]:
    """The held-out deliveries of kinds 1 to 3 of a composition run: its held-out values of the deliveries
    axes; binned by behaviour (a task of one kind of food, objective ``foraging``), its held-out fitness as
    kind 1's and no other kind."""
    if descriptor_set(entry["descriptors"]) in DELIVERY_SETS:
        return [_number(v) for v in values] if isinstance(values, list) else ["", "", ""]
    return [_number(fitness) if entry["objective"] == "foraging" else "", "", ""]


def finished_arm_runs(root: Path, document: dict) -> Iterator[tuple[dict, dict]]:
    """Each finished run of an arm (a composition or team run) of the plan ``document``, in the plan's
    order, with its summary."""
    for entry in document["plan"]:
        if entry["kind"] == "repertoire":
            continue
        summary = _summary(root, entry["dir"])
        if summary is not None:
            yield entry, summary


def study_plan(root: Path) -> dict:
    """The plan document of the study in ``root``; ``EvolutionError`` when it holds none."""
    document = read_json(Path(root) / PLAN_FILE)
    if not isinstance(document, dict) or document.get("study") != STUDY:
        raise EvolutionError(f"{root} is not a {STUDY} study ({PLAN_FILE})")
    return document


def _baseline_runs(finished: Sequence[tuple[dict, dict]]) -> list[tuple[dict, dict]]:
    """Each task's and index's baseline run among ``finished``: the first composition run, in the plan's
    order, whose summary holds the homogeneous baseline (every arm of a seed measures the same one)."""
    found: dict[tuple[str, object], tuple[dict, dict]] = {}
    for entry, summary in finished:
        if entry["kind"] == "composition" and summary.get("homogeneous"):
            found.setdefault((entry["task"], entry["seed"]), (entry, summary))
    return list(found.values())


def _held(summary: dict) -> tuple[tuple[int, ...], int]:
    """A run's held-out scenarios: their seeds and the trials of each."""
    return tuple(int(s) for s in summary["heldout"]["seeds"]), int(summary["heldout"]["trials"])


def _trained(summary: dict) -> tuple[tuple[int, ...], int]:
    """The scenario a composition run measured its baseline and, on fixed scenarios, its genomes on: its
    scenario seed and trials."""
    config = summary["config"]
    return (int(config["scenario_seed"]),), int(config["trials"])


def finished_rows(
    finished: Sequence[tuple[dict, dict]], unseen: dict[tuple[str, str], float] | None = None
) -> list[dict[str, str]]:
    """One row per finished arm run (``finished``: :func:`finished_arm_runs`), in the plan's order, each
    task's and index's baseline row (from its first arm's run) before its arms' rows; ``unseen``
    (:func:`unseen_scores`) gives the unseen-arena column."""
    unseen = unseen or {}
    rows: list[dict[str, str]] = []
    baselines: list[dict[str, str]] = []
    holders = {entry["dir"] for entry, _ in _baseline_runs(finished)}
    for entry, summary in finished:
        seed, task = str(entry["seed"]), entry["task"]
        if entry["kind"] == "team":
            means = summary.get("heldout_objectives") or {}
            rows.append({
                "arm": entry["arm"], "task": task, "seed": seed,
                "best_fitness": _number(summary["best_fitness"]),
                "heldout_best_fitness": _number(summary["heldout_best_fitness"]),
                **{f"heldout_foraging{k}": _number(means.get(f"foraging{k}")) for k in (1, 2, 3)},
                **{f"qd_score_{k}": "" for k in QD_SCORE_BINS},
                VALIDATED: _validated(summary.get("validated")),
                UNSEEN: _number(unseen.get((entry["dir"], "validated"))),
            })  # fmt: skip
            continue
        if entry["dir"] in holders:
            baseline = summary["homogeneous"]
            baselines.append({
                "arm": BASELINE, "task": task, "seed": seed,
                "best_fitness": _number(baseline["fitness"]),
                "heldout_best_fitness": _number(baseline["heldout_best_fitness"]),
                **dict(zip(HEADER[5:8], _kinds(
                    entry, baseline["heldout_best_fitness"], baseline["heldout_descriptors"]), strict=True)),
                **{f"qd_score_{k}": "" for k in QD_SCORE_BINS},
                VALIDATED: _validated(baseline.get("validated")),
                UNSEEN: _number(unseen.get((entry["dir"], BASELINE))),
            })  # fmt: skip
        scores = summary.get("qd_scores_evaluated", {})
        rows.append({
            "arm": entry["arm"], "task": task, "seed": seed,
            "best_fitness": _number(summary["best_fitness"]),
            "heldout_best_fitness": _number(summary["heldout_best_fitness"]),
            **dict(zip(HEADER[5:8], _kinds(
                entry, summary["heldout_best_fitness"], summary.get("heldout_descriptors")), strict=True)),
            **{f"qd_score_{k}": _number(scores.get(str(k))) for k in QD_SCORE_BINS},
            VALIDATED: _validated(summary.get("validated")),
            UNSEEN: _number(unseen.get((entry["dir"], "validated"))),
        })  # fmt: skip
    return baselines + rows


# Unseen arenas --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Chosen:
    """A validated choice to score on unseen arenas: its run folder, whose it is (``validated``: the run's;
    ``homogeneous``: the baseline's), the task, each robot's tree and the run's held-out seeds and trials."""

    folder: str
    swarm: str
    task: str
    trees: tuple[str, ...]
    seeds: tuple[int, ...]
    trials: int


def _chosen_swarms(finished: Sequence[tuple[dict, dict]]) -> list[_Chosen]:
    """Every finished arm run's validated choice, and each task's and index's baseline choice (from its
    baseline run, :func:`_baseline_runs`), in the plan's order."""
    found: list[_Chosen] = []
    holders = {entry["dir"] for entry, _ in _baseline_runs(finished)}
    for entry, summary in finished:
        held = _held(summary)
        chosen = summary.get("validated")
        if isinstance(chosen, dict):
            trees = list(chosen["trees"])
            if entry["kind"] == "team":  # a tree per sub-group: robot i runs tree i mod K
                trees = [trees[g] for g in summary["robot_groups"]]
            found.append(_Chosen(entry["dir"], "validated", entry["task"], tuple(trees), *held))
        if entry["dir"] in holders:
            choice = summary["homogeneous"].get("validated")
            if isinstance(choice, dict):
                found.append(_Chosen(entry["dir"], BASELINE, entry["task"], tuple(choice["trees"]), *held))
    return found


@dataclass(frozen=True)
class _Scoring:
    """A swarm to score once and keep in a study's CSV file: the row's identity (the values of the file's
    columns before ``seeds``), its task, each robot's tree, the scenarios and the message should it fail."""

    key: tuple[str, ...]
    task: str
    trees: tuple[str, ...]
    seeds: tuple[int, ...]
    trials: int
    failure: str


def _scored_once(
    path: Path,
    header: Sequence[str],
    wanted: Sequence[_Scoring],
    configs: dict[str, Config],
    objectives: dict[str, str],
) -> dict[tuple[str, ...], float]:
    """The mean fitness (the task's objective in ``objectives``) of each swarm ``wanted`` on its world in
    ``configs`` over its seeds and trials, by its key. Scores already in the CSV file ``path`` (columns
    ``header``: the key's, then ``seeds``, ``trials`` and ``fitness``) for the same seeds and trials are read
    back, not measured again; the file is rewritten, in the order of ``wanted``, when any was missing."""
    keys = list(header[:-3])
    kept: dict[tuple[str, ...], dict[str, str]] = {}
    if path.exists():
        kept = {tuple(r[k] for k in keys): r for r in csv.DictReader(io.StringIO(path.read_text()))}

    def recorded(w: _Scoring) -> bool:
        row = kept.get(w.key)
        return (
            row is not None and row["seeds"] == " ".join(map(str, w.seeds)) and int(row["trials"]) == w.trials
        )

    missing = [w for w in wanted if not recorded(w)]
    for task in dict.fromkeys(w.task for w in missing):
        mine = [w for w in missing if w.task == task]
        evaluator = BatchEvaluator(configs[task])
        requests = [SwarmRequest(SwarmLayout(w.trees), s, w.trials) for w in mine for s in w.seeds]
        results = iter(evaluator.evaluate(requests))
        k = OBJECTIVES.index(objectives[task])
        for w in mine:
            scores = [r.fitness[k] for r in (next(results) for _ in w.seeds) if r.fitness is not None]
            if len(scores) != len(w.seeds):
                raise EvolutionError(w.failure)
            kept[w.key] = {
                **dict(zip(keys, w.key, strict=True)), "seeds": " ".join(map(str, w.seeds)),
                "trials": str(w.trials), "fitness": repr(math.fsum(scores) / len(scores)),
            }  # fmt: skip
    if missing:
        buffer = io.StringIO()
        writer = csv.DictWriter(buffer, header, lineterminator="\n")
        writer.writeheader()
        writer.writerows(kept[w.key] for w in wanted)
        write_atomic(path, buffer.getvalue())
    return {w.key: float(kept[w.key]["fitness"]) for w in wanted}


def unseen_scores(
    root: Path, document: dict, finished: Sequence[tuple[dict, dict]]
) -> dict[tuple[str, str], float]:
    """The mean fitness of each validated choice of the finished arm runs ``finished`` on its task's unseen
    arenas (``unseen_twin``: the generated arenas no run evolves on) over the run's held-out seeds and
    trials, by (run folder, ``validated`` or ``homogeneous``). Scores are kept in the study's ``unseen.csv``
    and measured only once; a task without unseen arenas gets none."""
    objectives = {t["task"]: t["objective"] for t in document["tasks"]}
    twins = {}
    for task in objectives:
        try:
            twins[task] = unseen_twin(task).config(document["profile"])
        except TaskError:  # a task of one arena (or five) has none: its column stays empty
            continue
    wanted = [
        _Scoring(
            (c.folder, c.swarm), c.task, c.trees, c.seeds, c.trials,
            f"{c.folder}: its {c.swarm} swarm could not be evaluated on unseen arenas",
        )
        for c in _chosen_swarms(finished)
        if c.task in twins
    ]  # fmt: skip
    scores = _scored_once(Path(root) / UNSEEN_FILE, UNSEEN_HEADER, wanted, twins, objectives)
    return {(folder, swarm): score for (folder, swarm), score in scores.items()}


# A team's members as homogeneous swarms ------------------------------------------------------------------
@dataclass(frozen=True)
class _Member:
    """One tree of a team run's swarm (``best``: the run's best; ``validated``: its validated choice), to be
    run by every robot on the run's held-out scenarios."""

    folder: str
    swarm: str
    group: int
    task: str
    tree: str
    seeds: tuple[int, ...]
    trials: int


def _members(finished: Sequence[tuple[dict, dict]]) -> list[_Member]:
    """Every tree of the best and the validated swarm of each finished team run of two trees or more, in the
    plan's order."""
    found = []
    for entry, summary in finished:
        if entry["kind"] != "team" or int(summary["config"]["team"]) < 2:
            continue
        for swarm, choice in (("best", summary.get("best")), ("validated", summary.get("validated"))):
            if isinstance(choice, dict):
                for g, tree in enumerate(choice["trees"]):
                    found.append(_Member(entry["dir"], swarm, g, entry["task"], tree, *_held(summary)))
    return found


def member_scores(
    root: Path, document: dict, finished: Sequence[tuple[dict, dict]]
) -> dict[tuple[str, str, int], float]:
    """The mean fitness of each tree of the heterogeneous teams' best and validated swarms (:func:`_members`)
    run by every robot, on its run's held-out seeds and trials, by (run folder, ``best`` or ``validated``,
    sub-group): how far the team's own trees get as homogeneous swarms on the scenarios the team is scored
    on. Kept in the study's ``members.csv`` and measured only once."""
    objectives = {t["task"]: t["objective"] for t in document["tasks"]}
    configs = {task: task_named(task).config(document["profile"]) for task in objectives}
    wanted = [
        _Scoring(
            (m.folder, m.swarm, str(m.group)), m.task, (m.tree,) * configs[m.task].n_robots, m.seeds,
            m.trials, f"{m.folder}: tree {m.group} of its {m.swarm} swarm could not be evaluated",
        )
        for m in _members(finished)
    ]  # fmt: skip
    scores = _scored_once(Path(root) / MEMBERS_FILE, MEMBERS_HEADER, wanted, configs, objectives)
    return {(folder, swarm, int(group)): score for (folder, swarm, group), score in scores.items()}


BEST_MEMBER = "its best tree x all"
"""The second side of :func:`member_comparisons`: the best of a team's own trees as a homogeneous swarm."""


def member_comparisons(
    finished: Sequence[tuple[dict, dict]], scores: dict[tuple[str, str, int], float], tasks: Sequence[str]
) -> list[Comparison]:
    """Each heterogeneous team arm against the best of its own trees run by every robot (the highest of
    :func:`member_scores`, chosen on the very scenarios it is compared on, so in the trees' favour), run
    by run, on the held-out score of the run's best swarm and of its validated choice: one family,
    Holm-corrected. Arms of fewer than two runs are left out."""
    best_tree: dict[tuple[str, str], float] = {}  # (run folder, swarm): its best tree's score
    for (folder, swarm, _), score in scores.items():
        best_tree[(folder, swarm)] = max(score, best_tree.get((folder, swarm), -math.inf))
    found = []
    for key, swarm in ((HELDOUT, "best"), (VALIDATED, "validated")):
        for task in tasks:
            for arm in (a for a in ARMS if a.team >= 2):
                pairs = []
                for entry, summary in finished:
                    if entry.get("arm") != arm.name or entry["task"] != task:
                        continue
                    tree = best_tree.get((entry["dir"], swarm))
                    team = (
                        summary.get("heldout_best_fitness")
                        if swarm == "best"
                        else (summary.get("validated") or {}).get("heldout_best_fitness")
                    )
                    if tree is not None and team is not None:
                        pairs.append((float(team), tree))
                if len(pairs) >= 2:
                    a, b = zip(*pairs, strict=True)
                    found.append(compare_paired(METRICS[key], task, arm.name, a, BEST_MEMBER, b))
    return holm(found) if found else []


def _members_section(
    finished: Sequence[tuple[dict, dict]], scores: dict[tuple[str, str, int], float], tasks: Sequence[str]
) -> str:
    """The teams against their best own tree (:func:`member_comparisons`); nothing without two runs."""
    tested = member_comparisons(finished, scores, tasks)
    if not tested:
        return ""
    return (
        "## Is a team more than its best tree?\n\n"
        "A heterogeneous team could win only because one of its trees is a good forager that no homogeneous "
        "search found. So each team run's swarm (its best, and its validated choice) is paired with the best "
        "of its own trees run by every robot, on the same held-out scenarios (`members.csv`: every tree of "
        "each swarm so scored). The best tree is chosen on those very scenarios, which favours it. Where a "
        "team scores above it, the team's robots do better divided than any one of its trees does alone. "
        "Holm's correction over the family of every row of this table.\n\n" + markdown_table(tested) + "\n"
    )


# Hand-written swarms -------------------------------------------------------------------------------------
HANDWRITTEN = "hand-written: "
"""The prefix of a hand-written swarm's rows (``handwritten_swarms``), which pair with the baseline by seed
as the arms' do but stay out of ``runs.csv``."""


def handwritten_rows(
    root: Path, document: dict, finished: Sequence[tuple[dict, dict]]
) -> list[dict[str, str]]:
    """Every hand-written swarm (``handwritten_swarms``) on the held-out scenarios of each task's and
    index's baseline (``heldout_best_fitness``, with its kinds) and on the scenario the baseline's run
    evolved on (``best_fitness``: where the runs' own scores were measured), as rows of :data:`HEADER` (its
    arm :data:`HANDWRITTEN` and the swarm's name), measured once into the study's ``handwritten.csv``; none
    on a task without the benchmark's three food kinds."""
    baselines = [
        (e["task"], str(e["seed"]), (e["task"], *_held(s)), (e["task"], *_trained(s)))
        for e, s in _baseline_runs(finished)
    ]
    objectives = {t["task"]: t["objective"] for t in document["tasks"]}
    wanted = [scenarios for _, _, held, trained in baselines for scenarios in (held, trained)]
    found = handwritten_scores(root, document["profile"], objectives, wanted)
    rows = []
    for task, seed, held, trained in baselines:
        for swarm, own in zip(found.get(held, []), found.get(trained, []), strict=True):
            row = dict.fromkeys(HEADER, "")
            row.update(
                {
                    "arm": HANDWRITTEN + swarm["swarm"], "task": task, "seed": seed,
                    "best_fitness": own["fitness"], HELDOUT: swarm["fitness"],
                }
            )  # fmt: skip
            row.update({f"heldout_{column}": swarm[column] for column in KIND_COLUMNS})
            rows.append(row)
    return rows


def in_run_table(rows: Sequence[dict[str, str]], written: Sequence[dict[str, str]], task: str) -> str:
    """Each hand-written swarm's median score on the scenario the runs evolved on and on the held-out ones,
    each beside how many seeds' baselines score above it there (seed by seed): whether the score a search
    maximises can tell the swarm from the baseline. Empty without a baseline on ``task``."""
    base = {r["seed"]: r for r in rows if r["task"] == task and r["arm"] == BASELINE}
    if not base:
        return ""
    lines = [
        "| hand-written swarm | in-run | baselines above it in-run | held-out | baselines above it "
        "held-out |",
        "|---|---|---|---|---|",
    ]
    names = dict.fromkeys(r["arm"] for r in written if r["task"] == task)
    for name in names:
        mine = [r for r in written if r["task"] == task and r["arm"] == name and r["seed"] in base]
        cells = []
        for key in ("best_fitness", HELDOUT):
            above = sum(1 for r in mine if float(base[r["seed"]][key]) > float(r[key]))
            cells += [f"{_median([float(r[key]) for r in mine]):.3f}", f"{above} of {len(mine)}"]
        lines.append(f"| {name.removeprefix(HANDWRITTEN)} | " + " | ".join(cells) + " |")
    ins = sorted(float(b["best_fitness"]) for b in base.values())
    held = sorted(float(b[HELDOUT]) for b in base.values())
    return (
        "\n".join(lines)
        + f"\n\nThe baselines of {task}: in-run {ins[0]:.3f} to {ins[-1]:.3f}, held-out {held[0]:.3f} to "
        f"{held[-1]:.3f}.\n"
    )


def _handwritten_section(
    rows: Sequence[dict[str, str]], written: Sequence[dict[str, str]], tasks: Sequence[str]
) -> str:
    """The hand-written swarms against the baseline on the same held-out scenarios: the table, the tests (a
    family of their own) and, for the heterogeneous ones, the goal; nothing when there are none."""
    if not written:
        return ""
    names = list(dict.fromkeys(r["arm"] for r in written))
    both = [r for r in rows if r["arm"] == BASELINE] + list(written)
    tested = comparisons(both, tasks, HELDOUT, names)
    # the goal is against the best homogeneous swarm, which may be a homogeneous arm rather than the baseline
    homogeneous = homogeneous_arms(_arm_names())
    mixed = [HANDWRITTEN + name for name in HETEROGENEOUS] + homogeneous
    scored = both + [r for r in rows if r["arm"] in homogeneous]
    return (
        "## Hand-written swarms on the same held-out scenarios\n\n"
        "How far a swarm written by hand gets where the runs are scored, and so whether the task lets "
        "specialisation pay at all: the hand-written swarms of `division-bench` "
        "(`swarm_sim/bench/division.py`; the specialists run, on robot i, the forager of only kind i mod 3 + "
        "1) on the baseline's held-out scenarios, scored by the task's objective, paired with each index's "
        "baseline. Each is one swarm measured once: where the study's scenarios are shared, its score is the "
        "same for every index, so the tests (a family of their own, Holm-corrected) ask whether the evolved "
        "baselines differ from that one measurement, and its interval has no width. The goal lines apply "
        "the issue's test to the heterogeneous ones (swarms a person wrote, not ones the study evolved), "
        "against the best homogeneous swarm as the arms' goal lines do.\n\n"
        f"{scores_table(both, tasks, HELDOUT, names)}\n"
        + (markdown_table(tested) if tested else "No hand-written swarm has two paired runs yet.\n")
        + f"\n{goal_text(scored, tested, tasks, HELDOUT, mixed)}\n"
        + "\n### On the scenario the runs evolved on\n\n"
        "Every run is scored, while it evolves, on its one scenario (the study's design); the hand-written "
        "swarms measured there too show whether that score can tell them from the baselines. Where a "
        "hand-written swarm scores below most baselines in-run but above them held-out, a search maximising "
        "the in-run score prefers the baseline to it, however well it searches. Seeds whose scenarios are "
        "shared see the same in-run score for the swarm (one measurement).\n\n"
        + "\n".join(in_run_table(rows, written, task) for task in tasks)
        + "\n"
    )


def _paired(
    rows: Sequence[dict[str, str]], task: str, arm: str, key: str, against: str = BASELINE
) -> tuple[list[float], list[float]]:
    """The arm's and the baseline's (or ``against``'s) ``key`` on ``task``, paired by seed (seeds both
    have)."""
    mine = {r["seed"]: float(r[key]) for r in rows if r["task"] == task and r["arm"] == arm and r[key]}
    base = {r["seed"]: float(r[key]) for r in rows if r["task"] == task and r["arm"] == against and r[key]}
    seeds = [s for s in mine if s in base]
    return [mine[s] for s in seeds], [base[s] for s in seeds]


def _values(rows: Sequence[dict[str, str]], task: str, arm: str, key: str) -> list[float]:
    return [float(r[key]) for r in rows if r["task"] == task and r["arm"] == arm and r[key] != ""]


def _arm_names() -> tuple[str, ...]:
    return tuple(arm.name for arm in ARMS)


def comparisons(
    rows: Sequence[dict[str, str]], tasks: Sequence[str], key: str = HELDOUT, names: Sequence[str] = ()
) -> list[Comparison]:
    """Each arm (or each of ``names``) against the homogeneous baseline on the held-out score ``key`` (of
    the best on the run's scenario, or of the validated choice), paired by seed, per task: one family,
    Holm-corrected (every arm on every task). Pairs of fewer than two runs are left out."""
    metric = METRICS[key]
    found = []
    for task in tasks:
        for name in names or _arm_names():
            a, b = _paired(rows, task, name, key)
            if len(a) >= 2:
                found.append(compare_paired(metric, task, name, a, BASELINE, b))
    return holm(found) if found else []


def twin_comparisons(rows: Sequence[dict[str, str]], tasks: Sequence[str]) -> list[Comparison]:
    """Each arm that has a twin (``Arm.twin``) against it, on the held-out score of the run's best and of the
    validated choice, paired by seed, per task: one family, Holm-corrected. Pairs of fewer than two runs are
    left out."""
    found = []
    for key in (HELDOUT, VALIDATED):
        for task in tasks:
            for arm in (a for a in ARMS if a.twin):
                a, b = _paired(rows, task, arm.name, key, arm.twin)
                if len(a) >= 2:
                    found.append(compare_paired(METRICS[key], task, arm.name, a, arm.twin, b))
    return holm(found) if found else []


def _twins_section(rows: Sequence[dict[str, str]], tasks: Sequence[str]) -> str:
    """The arms against their twins (:func:`twin_comparisons`); nothing when no pair has two runs."""
    tested = twin_comparisons(rows, tasks)
    if not tested:
        return ""
    pairs = ", ".join(f"{a.name} against {a.twin}" for a in ARMS if a.twin)
    return (
        "## Against the homogeneous twin\n\n"
        "An arm that evolves several trees from a start tree is paired, seed by seed, with its twin: the "
        f"same GP over one tree from the same start, on the same budget and scenarios ({pairs}). Beside "
        "the baseline, which tells how far each gets, this tells what evolving several trees adds to what "
        "the start gives. Held-out scores of the run's best and of its validated choice; Holm's correction "
        "over the family of every row of this table.\n\n" + markdown_table(tested) + "\n"
    )


def _median(values: Sequence[float]) -> float:
    return float(np.median(values))


def scores_table(
    rows: Sequence[dict[str, str]], tasks: Sequence[str], key: str = HELDOUT, names: Sequence[str] = ()
) -> str:
    """Per task and arm (or each of ``names``, after the baseline): runs, median of the held-out score
    ``key`` with a 95 % bootstrap interval, the ratio of medians to the baseline's, the paired median
    difference with its interval, and for the best on the run's scenario the median held-out deliveries per
    kind."""
    rng = np.random.default_rng(0)
    lines = [
        "| task | arm | runs | held-out median [95 % CI] | / homogeneous | paired Δ median [95 % CI] | "
        "kind 1 | kind 2 | kind 3 |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for task in tasks:
        base = _values(rows, task, BASELINE, key)
        for name in (BASELINE, *(names or _arm_names())):
            held = _values(rows, task, name, key)
            if not held:
                continue
            bounds = interval(held, "median", rng)
            ci = "" if bounds is None else f" [{bounds[0]:.4g}, {bounds[1]:.4g}]"
            ratio = f"{_median(held) / _median(base):.3g}" if base and _median(base) > 0 else "n/a"
            delta = ""
            if name != BASELINE:
                a, b = _paired(rows, task, name, key)
                differences = [x - y for x, y in zip(a, b, strict=True)]
                if differences:
                    d_bounds = interval(differences, "median", rng)
                    delta = f"{_median(differences):+.4g}" + (
                        "" if d_bounds is None else f" [{d_bounds[0]:+.4g}, {d_bounds[1]:+.4g}]"
                    )
            kinds = [_values(rows, task, name, f"heldout_foraging{k}") for k in (1, 2, 3)]
            shown = [f"{_median(v):.3g}" if v and key == HELDOUT else "" for v in kinds]
            lines.append(
                f"| {task} | {name} | {len(held)} | {_median(held):.4g}{ci} | {ratio} | {delta} | "
                + " | ".join(shown)
                + " |"
            )
    return "\n".join(lines) + "\n"


def qd_table(rows: Sequence[dict[str, str]], tasks: Sequence[str]) -> str:
    """Per task and arm, the mean of the authors' QD score at 1, 2, 4 and 8 bins per axis over every genome
    each run evaluated (equal evaluations)."""
    head = " | ".join(f"{k} bins" for k in QD_SCORE_BINS)
    lines = [f"| task | arm | runs | {head} |", "|---|---|---|" + "---|" * len(QD_SCORE_BINS)]
    for task in tasks:
        for arm in ARMS:
            columns = [_values(rows, task, arm.name, f"qd_score_{k}") for k in QD_SCORE_BINS]
            if not columns[0]:
                continue
            means = " | ".join(f"{sum(c) / len(c):.4g}" for c in columns)
            lines.append(f"| {task} | {arm.name} | {len(columns[0])} | {means} |")
    return "\n".join(lines) + "\n"


def repertoire_table(root: Path, document: dict) -> str:
    """Per task, what its finished repertoires hold for the compositions to choose from: the bins filled of
    each repertoire's grid (median, least and most), the cells a composition run chooses among (a bin's
    elite in each objective's archive, ``repertoire_<objective>.json``), and for each food kind the fittest
    tree of that kind's archive as scored in-run, nine copies of it (median over the repertoires)."""
    lines = [
        "| task | repertoires | bins filled: median [least, most] | cells to compose from (median) "
        "| fittest tree per kind, in-run (median): kind 1 / kind 2 / kind 3 |",
        "|---|---|---|---|---|",
    ]
    for spec in document["tasks"]:
        task = spec["task"]
        filled, pool, kinds = [], [], []
        for entry in document["plan"]:
            if entry["kind"] != "repertoire" or entry["task"] != task or _summary(root, entry["dir"]) is None:
                continue
            cells, _ = read_sources([root / entry["dir"]])  # the cells a composition of it chooses among
            filled.append(len({cell.bin for cell in cells}))
            pool.append(len(cells))
            kinds.append(
                [
                    max((c.fitness for c in cells if c.objective == f"foraging{k}"), default=math.nan)
                    for k in (1, 2, 3)
                ]
            )
        if not filled:
            continue
        known = [[row[k] for row in kinds if not math.isnan(row[k])] for k in range(3)]
        per_kind = " / ".join(f"{_median(values):.3g}" if values else "n/a" for values in known)
        lines.append(
            f"| {task} | {len(filled)} | {_median(filled):g} [{min(filled)}, {max(filled)}] of "
            f"{math.prod(GRID_SHAPE)} | {_median(pool):g} | {per_kind} |"
        )
    return "\n".join(lines) + "\n" if len(lines) > 2 else "No repertoire has finished yet.\n"


def homogeneous_arms(names: Sequence[str]) -> list[str]:
    """The homogeneous arms among ``names``: those named ``homogeneous-...`` (one tree for every robot)."""
    return [n for n in names if n.startswith(f"{BASELINE}-")]


def best_homogeneous(rows: Sequence[dict[str, str]], task: str, key: str, names: Sequence[str] = ()) -> str:
    """The homogeneous arm the goal is measured against on ``task``: of the baseline and the homogeneous arms
    (:func:`homogeneous_arms` of ``names`` where given) with scores ``key``, the one of highest median; the
    baseline on a tie or where no other has scores."""
    arms = homogeneous_arms(names or _arm_names())
    scored = [(_median(v), n == BASELINE, n) for n in (BASELINE, *arms) if (v := _values(rows, task, n, key))]
    return max(scored, key=lambda s: (s[0], s[1]))[2] if scored else BASELINE


def goal_text(
    rows: Sequence[dict[str, str]],
    tested: Sequence[Comparison],
    tasks: Sequence[str],
    key: str = HELDOUT,
    names: Sequence[str] = (),
) -> str:
    """Whether an arm (or each of ``names``) reached the goal on a task: the median of the held-out score
    ``key`` at least :data:`GOAL` times the best homogeneous swarm's (:func:`best_homogeneous`) with the
    paired test significant after Holm's correction. Against the baseline the tests are ``tested``; where a
    homogeneous arm's median is higher, every candidate is tested against that arm instead, paired by seed,
    in a family of its own (shown with the lines). A homogeneous arm is no candidate: its line says how it
    stands to the baseline and how the best heterogeneous median stands to it."""
    arms = names or _arm_names()
    homogeneous = homogeneous_arms(arms)
    candidates = [n for n in arms if n not in homogeneous]
    against = {task: best_homogeneous(rows, task, key, arms) for task in tasks}
    moved = []
    for task in (t for t in tasks if against[t] != BASELINE):
        for name in candidates:
            a, b = _paired(rows, task, name, key, against[task])
            if len(a) >= 2:
                moved.append(compare_paired(METRICS[key], task, name, a, against[task], b))
    moved = holm(moved) if moved else []
    lines = []
    for task in tasks:
        base = _values(rows, task, BASELINE, key)
        if not base:
            continue
        best = max((_median(v) for n in candidates if (v := _values(rows, task, n, key))), default=None)
        for name in homogeneous:
            held = _values(rows, task, name, key)
            if held and best is not None and _median(base) > 0 and _median(held) > 0:
                lines.append(
                    f"- {task}, {name}: a homogeneous arm, no candidate; its median is "
                    f"{_median(held) / _median(base):.3g} times the baseline's ({len(held)} runs), and the "
                    f"best heterogeneous median {best / _median(held):.3g} times its own."
                )
        versus = against[task]
        reference = _values(rows, task, versus, key)
        family = tested if versus == BASELINE else moved
        for name in candidates:
            held = _values(rows, task, name, key)
            row = next((c for c in family if c.objective == task and c.first == name), None)
            if not held or row is None or _median(reference) <= 0:
                continue
            ratio = _median(held) / _median(reference)
            reached = ratio >= GOAL and row.significant and _median(held) > _median(reference)
            a, b = _paired(rows, task, name, key, versus)
            power = goal_power([x - y for x, y in zip(a, b, strict=True)], (GOAL - 1) * _median(reference))
            which = "the homogeneous median" if versus == BASELINE else f"{versus}'s median"
            runs = f"{len(held)} runs" + ("" if versus == BASELINE else f", {len(a)} paired with it")
            lines.append(
                f"- {task}, {name}: {ratio:.3g} times {which}, Holm-adjusted p "
                f"{row.p_holm:.3g} ({runs}): goal {'reached' if reached else 'not reached'}{power}."
            )
    if not lines:
        return "No arm has paired runs yet.\n"
    text = "\n".join(lines) + "\n"
    if moved:
        shifted = ", ".join(f"{t}: {against[t]}" for t in tasks if against[t] != BASELINE)
        text = (
            f"The best homogeneous swarm is not the baseline here ({shifted}: the homogeneous arm of highest "
            "median), so the goal is measured against it: each arm paired with it by seed, Holm's correction "
            "over the family of every row of this table.\n\n" + markdown_table(moved) + "\n" + text
        )
    return text


def paired_power(differences: Sequence[float], gain: float, alpha: float = 0.05) -> tuple[float, int] | None:
    """The power of a two-sided paired t-test at ``alpha`` to detect a mean paired difference of ``gain``,
    given the spread of ``differences`` and their number, and the number of pairs that would give it 80 %
    power (``statsmodels`` ``TTestPower``); None for fewer than three pairs or no spread. An upper bound
    for the report's tests, whose Holm correction asks for more."""
    if len(differences) < 3 or gain <= 0:
        return None
    spread = float(np.std(differences, ddof=1))
    if not spread > 0:
        return None
    # statsmodels (seconds to import, with scipy and pandas) loads only when a report is written
    from statsmodels.stats.power import TTestPower
    from statsmodels.tools.sm_exceptions import ConvergenceWarning

    effect = gain / spread
    analysis = TTestPower()
    power = float(analysis.power(effect_size=effect, nobs=len(differences), alpha=alpha))
    # the root finder gives up (NaN, with a warning) where so large an effect needs fewer than about 3 pairs:
    # then count up from 2, the fewest a paired t-test takes
    if analysis.power(effect_size=effect, nobs=2, alpha=alpha) >= 0.8:
        return power, 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        needed = float(analysis.solve_power(effect_size=effect, power=0.8, alpha=alpha))
    if not math.isfinite(needed):
        needed = next(n for n in itertools.count(3) if analysis.power(effect, n, alpha) >= 0.8)
    return power, math.ceil(needed)


def goal_power(differences: Sequence[float], gain: float) -> str:
    """The goal line's power clause: the power to detect the goal's paired gain, and the runs 80 % needs."""
    found = paired_power(differences, gain)
    if found is None:
        return ""
    power, needed = found
    return (
        f"; power to detect the goal's gain ({gain:.3g}, paired t-test at 0.05, before Holm) "
        f"{power:.2f}, 80 % at {needed} runs"
    )


def _figure(root: Path, rows: Sequence[dict[str, str]], tasks: Sequence[str]) -> list[str]:
    # matplotlib (about 1.5 s to import) loads only when figures are drawn
    from evolution_manager.viewing import figures

    samples = {
        task: {
            name: _values(rows, task, name, "heldout_best_fitness")
            for name in (BASELINE, *(arm.name for arm in ARMS))
            if _values(rows, task, name, "heldout_best_fitness")
        }
        for task in tasks
    }
    samples = {task: by_arm for task, by_arm in samples.items() if by_arm}
    if not samples:
        return []
    target = Path(root) / "figures" / "heldout_best_fitness.png"
    path = figures.boxes(samples, "held-out best fitness", target)
    return [f"![held-out best fitness](figures/{path.name})"]


# Who delivers what --------------------------------------------------------------------------------------
def robot_deliveries(trees: Sequence[str], config: Config, seeds: Sequence[int], trials: int) -> np.ndarray:
    """Each robot's mean deliveries of each food kind per trial (robots x kinds) of the swarm whose robot
    ``i`` runs ``trees[i]``, over ``trials`` trials of each of ``seeds`` (as an evaluation runs them: the
    batch road's kernels, ``record_trial``). Averaged over robots, a kind's column is its objective."""
    from swarm_sim.roads import record_trial  # late: the kernels load only for the figure

    layout = SwarmLayout(tuple(trees))
    total = np.zeros((config.n_robots, config.food_kinds))
    for seed in seeds:
        for trial in range(trials):
            total += record_trial(layout, seed, trial, config).deliveries[-1]
    return total / (len(seeds) * trials)


def _best_swarms(finished: Sequence[tuple[dict, dict]], task: str) -> dict[str, dict]:
    """The swarms of the figure on ``task``: the baseline and each arm's run of highest held-out best
    fitness (the first in plan order among equals), each as its label and trees."""
    shown: dict[str, dict] = {}
    for entry, summary in finished:
        if entry["task"] != task or summary["best"] is None:
            continue
        trees = summary["best"]["trees"]
        if entry["kind"] == "team":  # a tree per sub-group: robot i runs tree i mod K
            trees = [trees[i % len(trees)] for i in range(len(summary["robot_groups"]))]
        candidates = [(entry["arm"], summary["heldout_best_fitness"], trees, summary)]
        baseline = summary.get("homogeneous")
        if baseline:
            copies = [baseline["tree"]] * len(trees)
            candidates.append((BASELINE, baseline["heldout_best_fitness"], copies, summary))
        for name, held, trees, source in candidates:
            if held is None:
                continue
            if name not in shown or held > shown[name]["held"]:
                shown[name] = {"held": held, "trees": trees, "seeds": source["heldout"]["seeds"],
                               "trials": source["heldout"]["trials"], "seed": entry["seed"]}  # fmt: skip
    order = [BASELINE, *(arm.name for arm in ARMS)]
    return {name: shown[name] for name in order if name in shown}


def _deliveries_figures(root: Path, document: dict, finished: Sequence[tuple[dict, dict]]) -> list[str]:
    from evolution_manager.viewing import figures  # late: matplotlib

    drawn = []
    for spec in document["tasks"]:
        task = spec["task"]
        swarms = _best_swarms(finished, task)
        if not swarms:
            continue
        config = task_named(task).config(document["profile"])
        per_robot = {
            f"{name} (seed {s['seed'] % 10_000}, held-out {s['held']:.3g})": robot_deliveries(
                s["trees"], config, s["seeds"], s["trials"]
            )
            for name, s in swarms.items()
        }
        title = f"{task}: each robot's held-out deliveries per trial, by kind"
        path = figures.robot_deliveries(per_robot, title, root / "figures" / f"robots_{task}.png")
        drawn.append(f"![{title}](figures/{path.name})")
        if config.carries:
            drawn.append(carries_note(task, config.carries))
    return drawn


def carries_note(task: str, carries: Sequence[Sequence[str]]) -> str:
    """What the deliveries figure of ``task`` shows when its robots carry only some kinds (``carries``, as
    ``Config.carries``): the colours are the rule's, not the swarm's."""
    groups = "; ".join(f"group {g}: {', '.join(kinds)}" for g, kinds in enumerate(carries))
    return (
        f"On {task} robot i picks up only the kinds of group i mod {len(carries)} (`robots.carries`; "
        f"{groups}), so each robot's colour follows that rule in every swarm, homogeneous or not: here a "
        "specialised swarm shows in the heights of the bars, not in their colours."
    )


def _validated_section(rows: Sequence[dict[str, str]], tasks: Sequence[str]) -> str:
    """The scores, tests and goal again on the validated choices' held-out scores: a family of its own;
    nothing when no run has one."""
    if not any(r[VALIDATED] for r in rows):
        return ""
    tested = comparisons(rows, tasks, VALIDATED)
    return (
        "## The validated choice\n\n"
        "A run's best on its one scenario is partly that scenario's luck. Each run also re-scores its 10 "
        "best distinct genomes on 5 validation scenarios, apart from the held-out ones, and keeps the best "
        "there; the baseline is chosen alike among the cells' nine copies (`evolution/validation.py`). The "
        "same table, tests (a family of their own, Holm-corrected) and goal on the held-out scores of those "
        "choices:\n\n"
        f"{scores_table(rows, tasks, VALIDATED)}\n"
        + (markdown_table(tested) if tested else "No arm has two paired runs yet.\n")
        + f"\n{goal_text(rows, tested, tasks, VALIDATED)}\n"
    )


def _unseen_section(rows: Sequence[dict[str, str]], tasks: Sequence[str]) -> str:
    """The validated choices on arenas no run evolved on: the table, tests (a family of their own) and goal;
    nothing when no run has such a score."""
    if not any(r[UNSEEN] for r in rows):
        return ""
    tested = comparisons(rows, tasks, UNSEEN)
    return (
        "## Unseen arenas\n\n"
        "A block of five trials takes the generated arenas 0 to 4 of a layout's ten, so no run evolves on "
        "arenas 5 to 9. Each validated choice (the baseline's too) is scored on its task's twin on those "
        "arenas (`<task>-unseen`), on the run's held-out seeds and trials: the same table, tests (a family "
        "of their own, Holm-corrected) and goal:\n\n"
        f"{scores_table(rows, tasks, UNSEEN)}\n"
        + (markdown_table(tested) if tested else "No arm has two paired runs yet.\n")
        + f"\n{goal_text(rows, tested, tasks, UNSEEN)}\n"
    )


QD_RIVALS = (("qd", "ga"), ("qd", "qd-mix"))
"""The authors' MAP-Elites over compositions against the archives it is compared with at equal evaluations:
the authors' GA, and MAP-Elites with Mix-ME's mixing."""


def qd_comparisons(rows: Sequence[dict[str, str]], tasks: Sequence[str]) -> list[Comparison]:
    """``qd`` against each of its rivals (:data:`QD_RIVALS`) on the authors' QD score at every bin count,
    paired by seed (run k of each composes from the same repertoire on the same budget), per task: one
    family, Holm-corrected. Pairs of fewer than two runs are left out."""
    found = []
    for task in tasks:
        for bins in QD_SCORE_BINS:
            for first, second in QD_RIVALS:
                a, b = _paired(rows, task, first, f"qd_score_{bins}", second)
                if len(a) >= 2:
                    found.append(compare_paired(f"QD score, {bins} per axis", task, first, a, second, b))
    return holm(found) if found else []


def _qd_section(rows: Sequence[dict[str, str]], tasks: Sequence[str], spaces: str) -> str:
    """The QD scores' means (:func:`qd_table`) and MAP-Elites paired with its rivals (:func:`qd_comparisons`;
    no test table while no pair has two runs)."""
    tested = qd_comparisons(rows, tasks)
    rivals = " and ".join(dict.fromkeys(c.second for c in tested))
    return (
        "## The authors' QD score at 1, 2, 4 and 8 bins per axis\n\n"
        f"Every genome a run evaluated, binned by the task's behaviour space ({spaces}), the "
        "fittest kept per bin, summed and divided by the number of bins (their utilities.py); means over "
        "runs, at equal evaluations.\n\n"
        f"{qd_table(rows, tasks)}\n"
        + (
            f"The authors' MAP-Elites over compositions (qd) against {rivals} at each bin count, paired by "
            "seed (run k of every arm composes from the same repertoire, on the same budget); Holm's "
            "correction over the family of every row of this table.\n\n" + markdown_table(tested) + "\n"
            if tested
            else ""
        )
    )


def build_report(root: Path) -> Path:
    """Write ``runs.csv``, ``report.md`` and ``figures/`` of the study in ``root`` from its finished runs (the
    validated choices' scores on unseen arenas measured first where missing, ``unseen.csv``); return the
    report's path."""
    root = Path(root)
    document = study_plan(root)
    arm_runs = list(finished_arm_runs(root, document))  # every summary read once, for every table and figure
    rows = finished_rows(arm_runs, unseen_scores(root, document, arm_runs))
    if not rows:
        raise EvolutionError(f"{root} has no finished composition runs yet")
    members = member_scores(root, document, arm_runs)
    written = handwritten_rows(root, document, arm_runs)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(root / "runs.csv", buffer.getvalue())
    tasks = [t["task"] for t in document["tasks"]]
    # the behaviour spaces the plan bins by, as each describes itself (the deliveries' domain among them)
    spaces = "; ".join(dict.fromkeys(descriptor_set(t["descriptors"]).description for t in document["tasks"]))
    tested = comparisons(rows, tasks)
    arms = "\n".join(f"- **{arm.name}**: {arm.what}." for arm in ARMS if arm.name in document["arms"])
    planned = sum(1 for e in document["plan"] if e["kind"] != "repertoire")
    finished = len(rows) - sum(1 for r in rows if r["arm"] == BASELINE)
    text = (
        f"# When does a heterogeneous swarm beat the best homogeneous one? {root.name}\n\n"
        f"{finished} of {planned} planned runs of the arms finished ({document['runs']} per arm and task; "
        f"repertoires of {document['evaluations']:,} trees, compositions of "
        f"{document['swarm_evaluations']:,} genomes; {document['trials']} trials per evaluation, profile "
        f"{document['profile']}, design "
        f"{document['design']}); one row per run in [runs.csv](runs.csv).\n\n"
        "A composition arm composes one forager per robot from the cells of a MAP-Elites repertoire of trees "
        "evolved on the same task (binned by the deliveries of each food kind; on a task of one kind by the "
        "paper's movement, rotation and conditionality); a team arm evolves K trees "
        "together with no repertoire, on the budget of the repertoire and a composition run together. "
        "The arms:\n\n"
        f"{arms}\n- **{BASELINE}**: the best homogeneous swarm of the same cells (every cell's nine copies "
        "on the run's scenario, the fittest), measured by each composition run; the study takes it from the "
        "first arm's run of each seed.\n\n"
        "Held-out: the run's best swarm re-scored on five scenarios it never saw (mean); the baseline on the "
        "same five. Arms pair with the baseline by seed.\n\n"
        "## Scores\n\nMedians with 95 % bootstrap intervals (10,000 resamples); / homogeneous is the ratio "
        "of medians; the paired Δ is the median of the run-by-run differences to the baseline. Kinds: "
        "median held-out deliveries of each food kind per robot per trial.\n\n"
        f"{scores_table(rows, tasks)}\n"
        "## Does heterogeneity pay?\n\n"
        "Each arm against the homogeneous baseline on the held-out best fitness, paired by seed "
        "(Shapiro-Wilk on the differences, then a paired t-test or Wilcoxon signed-rank), Holm's "
        "correction over the family of every row of this table. Significant rows in bold.\n\n"
        + (markdown_table(tested) if tested else "No arm has two paired runs yet.\n")
        + f"\n### Against the goal ({GOAL} times the homogeneous median, p < 0.05 paired)\n\n"
        f"{goal_text(rows, tested, tasks)}\n"
        f"{_validated_section(rows, tasks)}"
        f"{_unseen_section(rows, tasks)}"
        f"{_twins_section(rows, tasks)}"
        f"{_members_section(arm_runs, members, tasks)}"
        f"{_handwritten_section(rows, written, tasks)}"
        f"{_qd_section(rows, tasks, spaces)}"
        "## What the repertoires hold\n\nA composition arm chooses each robot's tree among its "
        "repertoire's elites, so a swarm can specialise only as far as the repertoire holds trees for each "
        f"kind. Bins filled of the repertoire's grid ({spaces}; 8 bins per axis); the cells a composition "
        "chooses among (a bin's elite in "
        "each objective's archive); the fittest tree of each kind's archive, scored in-run as nine copies "
        "of it.\n\n"
        f"{repertoire_table(root, document)}\n"
        "## Figures\n\n" + "\n\n".join(_figure(root, rows, tasks)) + "\n\n"
        "## Who delivers what\n\nFor each task the baseline and each arm's best run (highest held-out best "
        "fitness): each robot's deliveries of each food kind per trial on the run's five held-out scenarios "
        "(seeds shown modulo 10,000). Where every robot picks up every kind, a specialised swarm shows "
        "robots of different colours.\n\n" + "\n\n".join(_deliveries_figures(root, document, arm_runs)) + "\n"
    )
    write_atomic(root / "report.md", text)
    return root / "report.md"
