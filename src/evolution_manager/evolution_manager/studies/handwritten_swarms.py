"""The hand-written swarms of ``swarm_sim``'s division benchmark (``swarm_sim.bench.division.swarms``:
foragers of any kind, of one kind, preferring one kind, of a random kind, a wanderer, and the specialists,
robot i fetching kind i mod 3 + 1) scored where a heterogeneity study scores its runs: on the held-out
scenarios of its baseline, on the study's profile and task, with the task's objective (issue 36). They say
how far a swarm written by hand gets on the same scenarios as the evolved ones, and so whether a task lets
specialisation pay at all. Measured once per task, scenarios and trials into the study's
``handwritten.csv``, read back by every report."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from pathlib import Path

from evolution_manager.errors import EvolutionError
from evolution_manager.files import write_atomic
from swarm_sim.bench.division import KINDS, swarms
from swarm_sim.evaluation import BatchEvaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, SwarmLayout
from swarm_sim.tasks import task_named

HANDWRITTEN_FILE = "handwritten.csv"
KIND_COLUMNS = tuple(f"foraging{k}" for k in KINDS)
HEADER = ["task", "swarm", "composition", "seeds", "trials", "fitness", *KIND_COLUMNS]
"""``handwritten.csv``: one row per task, hand-written swarm and held-out scenarios (their seeds, space
separated, and trials): the mean over the scenarios of the task's objective and of each kind's deliveries
per robot per trial."""

HETEROGENEOUS = tuple(
    name for name, (composition, _) in swarms(len(KINDS)).items() if composition == "heterogeneous"
)
"""The hand-written swarms that run different trees on different robots (the same for every swarm size)."""

Scenarios = tuple[str, tuple[int, ...], int]
"""A task, its held-out seeds and the trials of each."""


def _mean(outcomes: Sequence[Sequence[float] | None], objective: str) -> str:
    """The mean of ``objective`` over evaluations' fitness vectors (``OBJECTIVES`` order), as written."""
    k = OBJECTIVES.index(objective)
    return repr(math.fsum(f[k] for f in outcomes if f is not None) / len(outcomes))


def handwritten_scores(
    root: Path, profile: str, objectives: dict[str, str], wanted: Sequence[Scenarios]
) -> dict[Scenarios, list[dict[str, str]]]:
    """Every hand-written swarm on each of ``wanted`` whose task has the benchmark's three food kinds (the
    others get none), by scenarios: rows of :data:`HEADER`, in :func:`swarms`' order. ``objectives`` maps
    each task to the objective it is scored by. Rows already in ``root``'s ``handwritten.csv`` are kept; when
    any is missing it is measured and the file rewritten with exactly the wanted ones."""
    path = Path(root) / HANDWRITTEN_FILE
    kept: dict[tuple[str, str, str, str], dict[str, str]] = {}
    if path.exists():
        kept = {
            (r["task"], r["swarm"], r["seeds"], r["trials"]): r
            for r in csv.DictReader(io.StringIO(path.read_text()))
        }
    found: dict[Scenarios, list[dict[str, str]]] = {}
    measured = False
    for scenarios in dict.fromkeys(wanted):
        task, seeds, trials = scenarios
        config = task_named(task).config(profile)
        if config.food_kinds != len(KINDS):
            continue
        named = swarms(config.n_robots)
        key = (" ".join(map(str, seeds)), str(trials))
        missing = [name for name in named if (task, name, *key) not in kept]
        if missing:
            measured = True
            requests = [
                SwarmRequest(SwarmLayout(named[name][1]), s, trials) for name in missing for s in seeds
            ]
            results = iter(BatchEvaluator(config).evaluate(requests))
            for name in missing:
                outcomes = [next(results).fitness for _ in seeds]
                if any(fitness is None for fitness in outcomes):
                    raise EvolutionError(f"{task}: the hand-written swarm {name!r} could not be evaluated")
                kept[(task, name, *key)] = {
                    "task": task, "swarm": name, "composition": named[name][0], "seeds": key[0],
                    "trials": key[1], "fitness": _mean(outcomes, objectives[task]),
                    **{column: _mean(outcomes, column) for column in KIND_COLUMNS},
                }  # fmt: skip
        found[scenarios] = [kept[(task, name, *key)] for name in named]
    if measured:
        buffer = io.StringIO()
        writer = csv.DictWriter(buffer, HEADER, lineterminator="\n")
        writer.writeheader()
        writer.writerows(row for rows in found.values() for row in rows)
        write_atomic(path, buffer.getvalue())
    return found
