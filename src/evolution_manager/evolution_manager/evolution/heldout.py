"""Held-out scores: the repertoire of a finished run re-scored on scenarios it never saw.

Under ``fixed`` scenarios a run scores every tree on one scenario, so its best fitness and QD score may
reward trees that suit that scenario (overfitting). At the end of a run the best tree of every bin of each
evolved objective's repertoire, and the run's best tree, are evaluated ``HELDOUT_EVALUATIONS`` times (5) of
``trials`` trials each, on the held-out seeds of :meth:`~.config.RunConfig.heldout_seed` (the same five for
every tree, none of them a seed of the run). A tree's held-out fitness is the mean of its five fitnesses.

- held-out best fitness: the held-out fitness of the tree reported as the run's best (not the maximum
  over bins, which would select on noise again);
- held-out QD score: the sum over filled bins of the held-out fitness of the bin's best tree, / 512.

The scores are written to ``heldout.json`` in the run directory (and read back, not recomputed, when a
killed run is finished again). They depend only on the run's files and seeds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from evolution_manager.errors import RunDirectoryError
from evolution_manager.evolution.deap_trees import OBJECTIVES
from evolution_manager.evolution.run import Run
from evolution_manager.evolution.run_config import HELDOUT_EVALUATIONS
from evolution_manager.files import read_json, write_json
from swarm_sim.evaluation import EvaluationRequest, Evaluator

HELDOUT_FORMAT = 1


def heldout_path(run: Run) -> Path:
    """Where a run's held-out scores are written."""
    return run.directory.heldout


def saved_heldout(run: Run) -> dict | None:
    """The run's ``heldout.json`` when there is one and it belongs to this run's configuration, else None."""
    path = heldout_path(run)
    if not path.exists():
        return None
    saved = read_json(path)
    return saved if isinstance(saved, dict) and saved.get("config") == run.config.to_json() else None


def _trees(run: Run) -> list[str]:
    """The trees to re-score, in a fixed order: every bin's best, then the best trees, without repeats."""
    texts: dict[str, None] = {}
    for objective in run.config.objectives:
        for _, entry in run.repertoire(objective).best_entries():
            texts.setdefault(entry.tree, None)
        best = run.best(objective)
        if best is not None:
            texts.setdefault(best[0], None)
    return list(texts)


def score_heldout(run: Run, evaluator: Evaluator) -> dict:
    """Re-score the run's repertoires on the held-out seeds, write ``heldout.json`` and return it (or return
    the file already there, when it belongs to this run)."""
    saved = saved_heldout(run)
    if saved is not None:
        return saved

    seeds = [run.config.heldout_seed(repeat) for repeat in range(HELDOUT_EVALUATIONS)]
    trees = _trees(run)
    requests = [EvaluationRequest(tree, seed, run.config.trials) for tree in trees for seed in seeds]
    results = list(evaluator.evaluate(requests)) if requests else []
    if len(results) != len(requests):
        raise RunDirectoryError(f"the evaluator answered {len(results)} of {len(requests)} held-out requests")
    means: dict[str, list[float] | None] = {}
    for t, tree in enumerate(trees):
        chunk = results[t * len(seeds) : (t + 1) * len(seeds)]
        scored = [r.fitness for r in chunk if r.error is None and r.fitness is not None]
        if len(scored) < len(chunk):  # a tree that failed on any held-out scenario has no held-out score
            means[tree] = None
            continue
        means[tree] = [math.fsum(float(f[k]) for f in scored) / len(scored) for k in range(len(OBJECTIVES))]
    document: dict = {
        "format": HELDOUT_FORMAT,
        "config": run.config.to_json(),
        "seeds": seeds,
        "evaluations_per_tree": len(seeds),
        "trials": run.config.trials,
        "trees": len(trees),
        "objectives": {o: _objective(run, o, means) for o in run.config.objectives},
    }
    write_json(heldout_path(run), document)
    return document


def _objective(run: Run, objective: str, means: dict[str, list[float] | None]) -> dict:
    k = OBJECTIVES.index(objective)
    grid = run.repertoire(objective)
    bins = []
    for index, entry in grid.best_entries():
        held = means.get(entry.tree)
        bins.append(
            {
                "bin": list(index),
                "tree": entry.tree,
                "fitness": entry.value,
                "heldout_fitness": None if held is None else held[k],
            }
        )
    best = run.best(objective)
    best_means = None if best is None else means.get(best[0])
    best_held = None if best_means is None else best_means[k]
    return {
        "best_tree": None if best is None else best[0],
        "best_fitness": None if best is None else best[1],
        "heldout_best_fitness": best_held,
        "qd_score": grid.qd_score,
        "heldout_qd_score": heldout_qd_score(bins, grid.bin_count),
        "bins": bins,
    }


def heldout_qd_score(bins: Sequence[dict], bin_count: int = 512) -> float:
    """Sum over bins of the held-out fitness of the bin's best tree (0 for a tree that failed), / bins."""
    return math.fsum(b["heldout_fitness"] or 0.0 for b in bins) / bin_count
