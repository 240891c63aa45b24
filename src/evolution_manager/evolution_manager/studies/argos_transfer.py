"""Transfer in the paper experiment's report: each run's best tree scored in the authors' ARGoS simulation.

For every finished run and every objective it is compared on (GP_o and QD_o on their own, GP_fnd on all
three), the run's best tree (``summary.json``'s ``best_tree``, as evolved) is evaluated by the ARGoS
harness's driver on seeds ``1..20`` (each seed one full evaluation of 10 trials on fresh start poses, wheel
gains and message drops; ``swarm_sim.validation.transfer``) and here on as many fresh scenarios (our seeds
``1..20``, the run's trials and profile), and compared as the validation compares the two simulators
(``swarm_sim.validation.reference``: tolerance, z and verdict). Our held-out score of the tree stands beside
them: it is measured on 5 scenarios, which under the shared design are the same 5 for every run, so it carries
their difficulty, common to every algorithm. The driver's rows are kept in the experiment folder as
``argos_raw.tsv``, which doubles as a cache: rows already there are not run again, so the report is rebuilt
anywhere from the committed file without ARGoS. ``transfer.csv`` holds one row per run and objective.

The question the section answers: does any algorithm's best tree lose more in the authors' simulator than
here? Per objective and algorithm the loss is ours on fresh scenarios minus ARGoS, run by run; its mean is
tested against zero (Wilcoxon signed-rank, two-sided) and the algorithms' losses against each other with the
table-6 test (``significance.compare``), Holm over the section's rows.
"""

from __future__ import annotations

import csv
import io
import math
import statistics as stats
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from scipy import stats as scipy_stats

from evolution_manager.errors import UsageError
from evolution_manager.files import number, write_atomic
from evolution_manager.studies.significance import Comparison, compare, holm, markdown_table
from evolution_manager.viewing import figures
from swarm_sim.errors import UsageError as SimUsageError
from swarm_sim.model import PAPER_OBJECTIVES, Config
from swarm_sim.validation import reference as validation
from swarm_sim.validation import transfer
from swarm_sim.validation.cli import our_estimates

RAW_FILE = "argos_raw.tsv"
CSV_FILE = "transfer.csv"
DEFAULT_SEEDS = "1-20"
CSV_HEADER = [
    "algorithm",
    "objective",
    "run",
    "seed",
    "tree",
    "best_fitness",
    "heldout_best_fitness",
    "ours_fitness",
    "ours_sem",
    "ours_n",
    "argos_fitness",
    "argos_sem",
    "argos_n",
    "z",
    "verdict",
]


@dataclass(frozen=True)
class BestTree:
    """A run's best tree on one objective, with our scores of it."""

    label: str
    """The algorithm's name on this objective (``GP_nest``, ``GP_fnd``, ``QD_nest``)."""
    objective: str
    run: int
    seed: int
    tree: str
    best_fitness: float
    heldout: float | None


@dataclass(frozen=True)
class Transferred:
    """A best tree with its fitness here and in ARGoS on fresh scenarios, compared."""

    best: BestTree
    comparison: validation.Comparison
    """Ours against ARGoS on the tree's objective (``swarm_sim.validation.reference``)."""

    @property
    def ours(self) -> float:
        return self.comparison.ours.mean

    @property
    def argos(self) -> float:
        return self.comparison.theirs.mean

    @property
    def loss(self) -> float:
        """Ours minus ARGoS (positive: the tree does worse in ARGoS)."""
        return self.comparison.diff


class RunLike(Protocol):
    """What this module reads of a finished run (``report.FinishedRun``)."""

    @property
    def objective(self) -> str | None: ...
    @property
    def index(self) -> int: ...
    @property
    def summary(self) -> dict: ...
    def label(self, objective: str) -> str: ...


def best_trees(runs: Sequence[RunLike]) -> list[BestTree]:
    """Every run's best tree per objective it is compared on, in the runs' order."""
    picked = []
    for run in runs:
        for objective in PAPER_OBJECTIVES:
            if run.objective not in (None, objective):
                continue
            m = run.summary["objectives"][objective]
            held = m.get("heldout_best_fitness")
            picked.append(
                BestTree(
                    run.label(objective),
                    objective,
                    run.index,
                    int(run.summary["config"]["seed"]),
                    str(m["best_tree"]),
                    float(m["best_fitness"]),
                    None if held is None else float(held),
                )
            )
    return picked


def measure(
    root: Path, trees: Sequence[BestTree], driver: str | None, seeds: Sequence[int], jobs: int = 1
) -> None:
    """Evaluate in ARGoS every (tree, seed) not yet in ``root/argos_raw.tsv`` (appended there).
    UsageError when the harness or its build is missing or the driver fails."""
    raw = Path(root) / RAW_FILE
    try:
        have = transfer.read_argos_raw(raw)
        texts = list(dict.fromkeys(t.tree for t in trees))
        todo = [text for text in texts if any((text, s) not in have for s in seeds)]
        if not todo:
            return
        harness = transfer.ArgosHarness.from_environment(driver)
        harness.run(todo, seeds, raw, jobs, Path(root))
    except SimUsageError as error:
        raise UsageError(str(error)) from None
    finally:
        (Path(root) / "transfer_trees.txt").unlink(missing_ok=True)


def transferred(
    root: Path, trees: Sequence[BestTree], seeds: Sequence[int], world: Config, trials: int
) -> tuple[list[Transferred], int]:
    """The trees whose every seed is in ``root/argos_raw.tsv``, each scored here on as many fresh scenarios
    (our seeds ``1..len(seeds)``, ``trials`` trials each in ``world``'s model) and compared with ARGoS on
    its objective; and how many trees lack rows."""
    try:
        raw = transfer.read_argos_raw(Path(root) / RAW_FILE)
        argos, _ = transfer.argos_estimates(raw, [t.tree for t in trees], seeds)
    except SimUsageError as error:
        raise UsageError(str(error)) from None
    done = [t for t in trees if t.tree in argos]
    texts = list(dict.fromkeys(t.tree for t in done))
    ours = our_estimates(texts, list(range(1, len(seeds) + 1)), trials, world) if texts else {}
    rows = [
        Transferred(t, validation.compare(t.tree, ours[t.tree], argos[t.tree])[_INDEX[t.objective]])
        for t in done
    ]
    return rows, len(trees) - len(done)


_INDEX = {q: i for i, q in enumerate(validation.QUANTITIES)}


def write_csv(root: Path, rows: Sequence[Transferred]) -> Path:
    """``transfer.csv``: one row per run and objective, floats as exact decimal text."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_HEADER)
    for r in rows:
        b, c = r.best, r.comparison
        writer.writerow(
            [
                b.label,
                b.objective,
                str(b.run),
                str(b.seed),
                b.tree,
                number(b.best_fitness),
                number(b.heldout),
                number(c.ours.mean),
                number(c.ours.sem),
                str(c.ours.n),
                number(c.theirs.mean),
                number(c.theirs.sem),
                str(c.theirs.n),
                f"{c.z:.3f}",
                c.verdict,
            ]
        )
    path = Path(root) / CSV_FILE
    write_atomic(path, buffer.getvalue())
    return path


def _labels(objective: str) -> list[str]:
    return [f"GP_{objective}", "GP_fnd", f"QD_{objective}"]


def _losses(rows: Sequence[Transferred]) -> dict[str, dict[str, list[float]]]:
    losses: dict[str, dict[str, list[float]]] = {
        o: {label: [] for label in _labels(o)} for o in PAPER_OBJECTIVES
    }
    for r in rows:
        losses[r.best.objective][r.best.label].append(r.loss)
    return losses


def signed_rank_p(values: Sequence[float]) -> float | None:
    """Two-sided Wilcoxon signed-rank p-value of ``values`` against zero; None when it cannot be computed
    (fewer than 2 values, or all zero)."""
    if len(values) < 2 or all(v == 0.0 for v in values):
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(scipy_stats.wilcoxon(values).pvalue)


def comparisons(rows: Sequence[Transferred]) -> list[Comparison]:
    """The algorithms' losses against each other per objective (the three pairs), Holm over them."""
    losses = _losses(rows)
    out = []
    for objective in PAPER_OBJECTIVES:
        gp, fnd, qd = _labels(objective)
        for first, second in ((gp, fnd), (gp, qd), (fnd, qd)):
            a, b = losses[objective][first], losses[objective][second]
            if a and b:
                out.append(compare("loss in ARGoS", objective, first, a, second, b))
    return holm(out)


def _cell(values: Sequence[float]) -> str:
    if not values:
        return "n/a"
    if len(values) == 1:
        return f"{values[0]:.4f}"
    return f"{stats.mean(values):.4f} ± {stats.stdev(values) / math.sqrt(len(values)):.4f}"


def section(rows: Sequence[Transferred], missing: int, seeds: Sequence[int], folder: Path) -> str:
    """The report's section: the table per objective and algorithm, the comparisons and the figure."""
    seed_text = transfer.seeds_text(seeds)
    n = len(seeds)
    lines = [
        "## Transfer: each run's best tree in the authors' ARGoS (beyond the paper)\n",
        f"Each run's best tree on each objective it is compared on, scored in the authors' ARGoS code (their "
        f"2023 commit, through the project's harness; seeds {seed_text}, each a full evaluation of 10 "
        f"trials on fresh start poses, wheel gains and message drops) and here on {n} fresh scenarios "
        f"(our seeds 1-{n}, no run evolved on them). Loss: ours minus ARGoS, run by run (positive: the tree "
        "does worse in ARGoS); mean ± standard error over runs. Indistinguishable: the tree's own fitness "
        "within the validation's tolerance with |z| <= 4 (`docs/model.md`). Held-out: our held-out score "
        "(5 scenarios; under the shared design the same 5 for every run, so it carries their difficulty, "
        f"common to every algorithm). Every tree in [{CSV_FILE}]({CSV_FILE}); ARGoS's rows in the "
        f"experiment folder's `{RAW_FILE}`. Wilcoxon p: the loss against zero (signed-rank, two-sided, "
        "uncorrected).\n",
    ]
    if missing:
        lines.append(
            f"**{missing} best trees are not yet scored in ARGoS** and are left out (`report DIR "
            "--argos-eval DRIVER` scores them).\n"
        )
    lines += [
        "| objective | algorithm | runs | in-run best | held-out | ours, fresh | ARGoS | loss "
        "| indistinguishable | largest abs(z) | Wilcoxon p |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for objective in PAPER_OBJECTIVES:
        for label in _labels(objective):
            group = [r for r in rows if r.best.objective == objective and r.best.label == label]
            loss = [r.loss for r in group]
            p = signed_rank_p(loss)
            same = sum(r.comparison.verdict == validation.INDISTINGUISHABLE for r in group)
            worst = f"{max(abs(r.comparison.z) for r in group):.1f}" if group else "n/a"
            lines.append(
                f"| {objective} | {label} | {len(group)} | {_cell([r.best.best_fitness for r in group])} "
                f"| {_cell([r.best.heldout for r in group if r.best.heldout is not None])} "
                f"| {_cell([r.ours for r in group])} | {_cell([r.argos for r in group])} | {_cell(loss)} "
                f"| {same} of {len(group)} | {worst} | {'n/a' if p is None else f'{p:.4f}'} |"
            )
    table = comparisons(rows)
    if table:
        lines += [
            "",
            "Does one algorithm's best tree lose more than another's? The losses compared as table 6 "
            "compares its samples, Holm over these rows:\n",
            markdown_table(table).rstrip("\n"),
        ]
    if rows:
        points: dict[str, dict[str, list[tuple[float, float]]]] = {
            o: {label: [] for label in _labels(o)} for o in PAPER_OBJECTIVES
        }
        for r in rows:
            points[r.best.objective][r.best.label].append((r.ours, r.argos))
        path = figures.transfer_scatter(points, folder / "transfer_argos.png")
        lines += ["", f"![ours against ARGoS](figures/{path.name})"]
    return "\n".join(lines) + "\n"


def parse_seeds(text: str) -> list[int]:
    """``--argos-seeds``: N, A-B or a comma-separated list (``swarm_sim.validation.transfer.parse_seeds``)."""
    try:
        return transfer.parse_seeds(text)
    except SimUsageError as error:
        raise UsageError(str(error).replace("--seeds", "--argos-seeds")) from None


__all__ = [
    "BestTree",
    "Transferred",
    "best_trees",
    "comparisons",
    "measure",
    "parse_seeds",
    "section",
    "signed_rank_p",
    "transferred",
    "write_csv",
]
