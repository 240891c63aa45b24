"""The bt-vs-nn study's best tree and best network of each objective in the authors' ARGoS (issue 37).

``report DIR --argos-eval DRIVER`` on a bt-vs-nn study scores, through the project's ARGoS harness, each
objective's best tree (``gp`` or ``qd``) and best network (``nn-cmaes``, ``nn-ga`` or ``nn-qd``), the runs of
the highest held-out best fitness (``networks_study.best_controllers``), on seeds 1-20:

- a tree of a primitive in the authors' 2024 code in 20 s trials (the harness's build ``primitives``), a
  forager in their 2024 foraging setting (``foraging``, 100 s trials);
- a network in their 2026 code's footbot_nn (``ArgosHarness.run_networks``), in trials of the same lengths.

The rows stay in the study's folder (``argos_raw_trees_<task>.tsv``, ``argos_raw_networks.tsv``), so a later
report needs no ARGoS. The report's section sets each controller's objective there beside ours on the same
seeds (``validate``'s estimates: 10 trials a seed, the run's task and profile), with the tolerance of
``docs/model.md``. footbot_nn scores ifood from the food estimates, where our model (and the authors' tree
controller) uses the true distance (``docs/validation/README.md``, "Neural controllers"): a network's ifood
row compares two definitions.
"""

from __future__ import annotations

import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from evolution_manager.errors import UsageError
from swarm_ros.safe_paths import refuse_links
from swarm_sim.errors import UsageError as SimUsageError
from swarm_sim.tasks import task_named
from swarm_sim.validation import reference as validation
from swarm_sim.validation import transfer
from swarm_sim.validation.cli import our_estimates

TRIAL_SECONDS = {"primitives": 20, "foraging": 100}
"""Each task's trial length in ARGoS (the authors' 160- and 800-step trials)."""

OUR_TRIALS = 10
"""Our trials per seed: as many as ARGoS runs per evaluation (two runs of five)."""

NETWORKS_RAW = "argos_raw_networks.tsv"
"""The network rows' file in the study's folder."""

DEFINED_OTHERWISE = ("ifood",)
"""Objectives footbot_nn scores otherwise than this model does."""


@dataclass(frozen=True)
class Best:
    """An objective's best controller of one kind: the run's arm, seed and folder, its held-out best fitness
    and the controller as the harness reads it (a tree, or ``nn: w1 ... w56``)."""

    objective: str
    kind: str
    """``tree`` or ``network``."""
    arm: str
    seed: str
    folder: str
    subject: str
    heldout: float | None


def network_subject(weights: Sequence[float]) -> str:
    """A network as the harness reads it: ``nn: w1 ... w56``, each weight as Python prints it (exact)."""
    return f"{validation.NETWORK_PREFIX} " + " ".join(repr(float(w)) for w in weights)


def task_of(objective: str) -> str:
    """The task the study evolves ``objective`` on."""
    return "foraging" if objective == "foraging" else "primitives"


def trees_raw(root: Path, task: str) -> Path:
    """The tree rows' file of ``task`` in the study's folder."""
    return Path(root) / f"argos_raw_trees_{task}.tsv"


def has_rows(root: Path) -> bool:
    """Whether the study's folder holds any ARGoS rows (then its report has the ARGoS section)."""
    raws = [trees_raw(root, task) for task in TRIAL_SECONDS] + [Path(root) / NETWORKS_RAW]
    return any(raw.exists() for raw in raws)


def measure(
    root: Path, bests: Sequence[Best], driver: str | None, seeds: Sequence[int], jobs: int = 1
) -> None:
    """Evaluate in ARGoS every (controller, seed) of ``bests`` not yet in the study's raw files; UsageError
    when the harness, its build or the driver fails."""
    root = Path(root)
    try:
        harness = transfer.ArgosHarness.from_environment(driver)
        for task, seconds in TRIAL_SECONDS.items():
            mine = [b for b in bests if task_of(b.objective) == task]
            trees = [b.subject for b in mine if b.kind == "tree"]
            # every driver row has its wall time: the column that says which (tree, seed) are there
            have = transfer.read_raw_column(trees_raw(root, task), "argos_wall_s", task)
            if any((tree, s) not in have for tree in trees for s in seeds):
                refuse_links(trees_raw(root, task))  # the driver appends to it
                harness.run(trees, seeds, trees_raw(root, task), jobs, root, build=task)
            networks = [b.subject for b in mine if b.kind == "network"]
            harness.run_networks(networks, seeds, seconds, root / NETWORKS_RAW, root)
    except SimUsageError as error:
        raise UsageError(str(error)) from None
    finally:
        (root / "transfer_trees.txt").unlink(missing_ok=True)
        shutil.rmtree(root / "argos_network_run", ignore_errors=True)


def argos_values(root: Path, best: Best, seeds: Sequence[int]) -> list[float] | None:
    """ARGoS's value of the objective on each seed, or None when a seed's row is missing."""
    task = task_of(best.objective)
    if best.kind == "network":
        rows = transfer.read_network_raw(Path(root) / NETWORKS_RAW)
        slot = transfer.NETWORK_SLOTS.index(best.objective)
        found = [rows.get((best.subject, s, TRIAL_SECONDS[task])) for s in seeds]
        return None if any(v is None for v in found) else [v[slot] for v in found if v is not None]
    column = transfer.read_raw_column(trees_raw(root, task), best.objective, task)
    values = [column.get((best.subject, s)) for s in seeds]
    return None if any(v is None for v in values) else [v for v in values if v is not None]


def comparisons(
    root: Path, bests: Sequence[Best], seeds: Sequence[int], profile: str
) -> tuple[list[tuple[Best, validation.Comparison]], int]:
    """Each controller with every seed in ARGoS, ours beside it on its objective; and how many lack rows."""
    scored = [(best, values) for best in bests if (values := argos_values(root, best, seeds)) is not None]
    ours: dict[str, dict[str, validation.Estimate]] = {}
    for task in TRIAL_SECONDS:  # one batch per task
        subjects = list(dict.fromkeys(b.subject for b, _ in scored if task_of(b.objective) == task))
        if subjects:
            config = task_named(task).config(profile)
            ours.update(our_estimates(subjects, list(seeds), OUR_TRIALS, config))
    done = [
        (
            b,
            validation.Comparison(
                b.subject, b.objective, ours[b.subject][b.objective], validation.estimate(v)
            ),
        )
        for b, v in scored
    ]
    return done, len(bests) - len(done)


def section(root: Path, bests: Sequence[Best], seeds: Sequence[int], profile: str) -> str:
    """The report's transfer section: a row per controller with its ARGoS rows, and what is missing."""
    done, missing = comparisons(root, bests, seeds, profile)
    lines = [
        "## In the authors' ARGoS\n",
        f"Each objective's best tree and best network (the runs of the highest held-out best fitness), seeds "
        f"{transfer.seeds_text(seeds)}: trees in the authors' 2024 code (the six primitives in 20 s trials, "
        "foraging in their 100 s foraging setting), networks in their 2026 footbot_nn in trials of the same "
        f"lengths; here, the same seeds of {OUR_TRIALS} trials on the run's task under the study's profile. "
        "Mean ± standard error over the seeds; the verdict is `docs/model.md`'s tolerance (3√2 of ARGoS's "
        "standard error plus 0.03; indistinguishable when |z| ≤ 4 too). footbot_nn scores ifood from the "
        "food estimates and this model from the true distance: a network's ifood row (marked †) compares two "
        f"definitions. Rows: `argos_raw_trees_<task>.tsv`, `{NETWORKS_RAW}`.\n",
        "| objective | controller | held-out here | here | ARGoS | difference | z | verdict |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for best, c in done:
        mark = " †" if best.kind == "network" and best.objective in DEFINED_OTHERWISE else ""
        held = "n/a" if best.heldout is None else f"{best.heldout:.4g}"
        lines.append(
            f"| {best.objective}{mark} | {best.kind}, {best.arm} seed {best.seed} | {held} | "
            f"{c.ours.mean:.4f} ± {c.ours.sem:.4f} | {c.theirs.mean:.4f} ± {c.theirs.sem:.4f} | "
            f"{c.diff:+.4f} | {c.z:+.2f} | {c.verdict} |"
        )
    if not done:
        lines.append("| (none scored yet) | | | | | | | |")
    tail = (
        f"\n{missing} of {len(bests)} controllers lack ARGoS rows (`report DIR --argos-eval DRIVER` scores "
        "them).\n"
    )
    return "\n".join(lines) + "\n" + (tail if missing else "")


__all__ = [
    "Best",
    "argos_values",
    "comparisons",
    "has_rows",
    "measure",
    "network_subject",
    "section",
    "task_of",
    "trees_raw",
]
