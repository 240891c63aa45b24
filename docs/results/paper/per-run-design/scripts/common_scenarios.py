"""Table 6's nest rows: how much one scenario moves a tree's fitness, and the best nest trees of the three
algorithms scored on common scenarios (the same 10 for every tree).

    source ws/env.sh && python docs/results/paper/per-run-design/scripts/common_scenarios.py experiments/paper

For each run of GP_nest, GP_fnd and QD_nest it takes the best nest tree and evaluates it (10 trials) on the
scenario seeds of the 10 GP_nest runs; it prints per algorithm the in-run best fitness, the mean on the common
scenarios, the spread of one tree's fitness across scenarios, and Welch tests on the common-scenario means.
"""

import json
import statistics
import sys
from pathlib import Path

from scipy import stats

from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import OBJECTIVES

NEST = OBJECTIVES.index("nest")


def best_trees(runs: Path, label: str) -> list[tuple[str, int, float]]:
    """(best nest tree, its run's scenario seed, its in-run fitness) of every run of ``label``."""
    out = []
    for run in sorted((runs / label).iterdir()):
        summary = json.loads((run / "summary.json").read_text())
        nest = summary["objectives"]["nest"]
        out.append((nest["best_tree"], summary["config"]["scenario_seed"], nest["best_fitness"]))
    return out


def main(experiment: Path) -> None:
    runs = experiment / "runs"
    best = {label: best_trees(runs, label) for label in ("GP_nest", "GP_fnd", "QD_nest")}
    common = [seed for _, seed, _ in best["GP_nest"]]
    evaluator = BatchEvaluator()
    means: dict[str, list[float]] = {}
    for label, items in best.items():
        spreads, in_run = [], []
        for tree, _, fitness in items:
            requests = [EvaluationRequest(tree, seed, 10) for seed in common]
            values = [result.fitness[NEST] for result in evaluator.evaluate(requests)]
            means.setdefault(label, []).append(statistics.mean(values))
            spreads.append(statistics.stdev(values))
            in_run.append(fitness)
        mean, sd = statistics.mean(in_run), statistics.stdev(in_run)
        print(
            f"{label}: in-run best {mean:.4f} (sd over runs {sd:.4f}); "
            f"on the {len(common)} common scenarios {statistics.mean(means[label]):.4f} "
            f"(sd over runs {statistics.stdev(means[label]):.4f}); "
            f"one tree's sd across scenarios: {statistics.mean(spreads):.4f} on average"
        )
    for a, b in (("GP_nest", "GP_fnd"), ("GP_nest", "QD_nest")):
        p = stats.ttest_ind(means[a], means[b], equal_var=False).pvalue
        first, second = statistics.mean(means[a]), statistics.mean(means[b])
        print(f"common scenarios: {a} {first:.4f} vs {b} {second:.4f}: Welch p = {p:.4f}")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
