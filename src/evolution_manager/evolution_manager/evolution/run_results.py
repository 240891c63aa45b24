"""What a run's result files show that must be computed: held-out scores and trees as people read them.

``viewing.results`` only writes; everything it shows that takes a simulation or a simplification is computed
here, in one place, and handed to it as :class:`RunResults`:

- the held-out scores (``heldout``): re-scored now when an evaluator is given and the run is finished, else
  the run's own ``heldout.json`` when it belongs to this run, else none;
- the shown form of every tree the files name (``shown``): simplified, each primitive's copy kept whole and
  written by its name (``shown_trees.simplified``; without a library that is the run's clone key
  ``Run.forms``, mostly computed already);
- the best tree of each evolved objective (``best_trees``), parsed and simplified, for ``best/``.
"""

from __future__ import annotations

from dataclasses import dataclass

from bt_controller.language import Node, parse, to_text
from evolution_manager.evolution.heldout import saved_heldout, score_heldout
from evolution_manager.evolution.run import Run
from evolution_manager.evolution.shown_trees import simplified, simplified_tree
from swarm_sim.evaluation import Evaluator


@dataclass(frozen=True)
class BestTree:
    """The best tree of an evolved objective as ``best/<objective>.*`` shows it."""

    objective: str
    text: str
    """As evolved."""
    fitness: float
    evaluation: int
    """The first evaluation of ``text``."""
    original: Node
    shown: Node
    """``original`` simplified, each primitive's copy kept whole."""
    shown_text: str
    """``shown`` as text, each primitive's copy written by its name."""


@dataclass(frozen=True)
class RunResults:
    """Everything computed that a run's result files show (see the module's text)."""

    heldout: dict | None
    """The document of ``heldout.json``, or None."""
    heldout_scored: bool
    """Whether ``heldout`` was scored (and ``heldout.json`` written) for these results."""
    shown: dict[str, str]
    """Every tree text of the run's grids, archive and best trees -> its shown form."""
    best_trees: list[BestTree]
    """The best tree of each evolved objective that has one, in the run's order of objectives."""


def shown_form(run: Run, tree: str) -> str:
    """``simplified(tree, run.library)``; without a library that is the run's clone key, which the run
    has mostly computed already (``run.forms``)."""
    return run.forms(tree) if run.library is None else simplified(tree, run.library)


def run_results(run: Run, evaluator: Evaluator | None = None) -> RunResults:
    """Compute what ``run``'s result files show; with an ``evaluator`` a finished run's repertoires are first
    re-scored on held-out scenarios (``heldout.score_heldout``, which writes ``heldout.json``)."""
    scored = evaluator is not None and run.done
    heldout = score_heldout(run, evaluator) if evaluator is not None and run.done else saved_heldout(run)
    trees: list[str] = []
    for objective in run.config.grids:
        trees += [item.tree for item in run.repertoire(objective).items()]
        best = run.best(objective)
        if best is not None:
            trees.append(best[0])
    archive = run.archive()
    if archive is not None:
        trees += [item.tree for item in archive.items()]
    shown = {tree: shown_form(run, tree) for tree in trees}
    best_trees = []
    for objective in run.config.objectives:
        best = run.best(objective)
        if best is None:
            continue
        text, value, _ = best
        original = parse(text, library=run.library)
        tree = simplified_tree(original, run.library)
        best_trees.append(
            BestTree(
                objective=objective,
                text=text,
                fitness=value,
                evaluation=run.first_evaluation(text),
                original=original,
                shown=tree,
                shown_text=to_text(tree) if run.library is None else run.library.fold(tree),
            )
        )
    return RunResults(heldout=heldout, heldout_scored=scored, shown=shown, best_trees=best_trees)
