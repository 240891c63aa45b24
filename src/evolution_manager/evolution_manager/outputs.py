"""What a finished run leaves for a person to open: repertoires, summary, figures and the best trees.

``repertoire_<objective>.json``
    the passive grid of that objective: bin, tree text, fitness, descriptors and evaluation index of every
    tree it holds (for MAP-Elites, the grid of its own objective is its archive, also in ``archive.json``);
``summary.json``
    configuration, evaluations, and under ``objectives`` per objective the best fitness and tree,
    coverage, QD score and repertoire size (deterministic: same seed, same file);
``timing.json``
    wall-clock seconds in the evaluator and in the algorithm's own work, evaluations per second;
``figures/``
    ``heatmap_<objective>.png`` (fig. 7), ``histogram.png`` (fig. 8), ``progress.png``;
``best/<objective>.*``
    the best tree of each evolved objective, simplified (``bt_controller.simplify``: the same motors on every
    tick), as text, an indented view, BehaviorTree.CPP XML, Graphviz DOT, an SVG and a PNG drawing, and the
    tree as evolved in ``<objective>.original.txt``; a format that cannot be written is an error;
``explorer.html``
    the repertoire explorer (``evolution_manager.explorer``), one self-contained page.

Trees are shown to people simplified, with the original kept: every item of a repertoire file has ``tree``
(as evolved) and ``simplified``; the summary has ``best_tree`` and ``best_tree_simplified``.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

from bt_controller.formats import to_dot, to_xml
from bt_controller.render import render
from bt_controller.simplify import simplify
from bt_controller.tree import parse, to_indented, to_text

from .archive import Repertoire
from .files import write_atomic, write_json
from .primitives import DESCRIPTORS, OBJECTIVES
from .run import Run, RunDirectory


@cache
def simplified(tree: str) -> str:
    """The simplified text of a tree text (``bt_controller.simplify``)."""
    return to_text(simplify(parse(tree)))


def repertoire_document(repertoire: Repertoire, objective: str, run: Run) -> dict:
    """A repertoire as the JSON document of ``repertoire_<objective>.json``."""
    best = repertoire.best()
    return {
        "objective": objective,
        "algorithm": run.config.algorithm,
        "run": run.config.label,
        "seed": run.config.seed,
        "evaluations": run.evaluations,
        "shape": list(repertoire.shape),
        "items_per_bin": repertoire.items_per_bin,
        "descriptors": list(DESCRIPTORS),
        "coverage": repertoire.coverage,
        "qd_score": repertoire.qd_score,
        "best_fitness": best.value if best else None,
        "size": len(repertoire),
        "items": [
            {
                "bin": list(item.bin),
                "tree": item.tree,
                "simplified": simplified(item.tree),
                "fitness": item.fitness,
                "descriptors": list(item.descriptors),
                "evaluation": item.evaluation,
            }
            for item in repertoire.items()
        ],
    }


def summary_document(run: Run) -> dict:
    """The deterministic summary of a run (no timings)."""
    metrics = {}
    for objective in OBJECTIVES:
        grid = run.passive[objective]
        best = grid.best()
        metrics[objective] = {
            "evolved": objective in run.config.objectives,
            "best_fitness": best.value if best else None,
            "best_tree": best.tree if best else None,
            "best_tree_simplified": simplified(best.tree) if best else None,
            "best_descriptors": list(best.descriptors) if best else None,
            "best_evaluation": best.evaluation if best else None,
            "coverage": grid.coverage,
            "qd_score": grid.qd_score,
            "repertoire_size": len(grid),
        }
    return {
        "run": run.config.label,
        "config": run.config.to_json(),
        "evaluations": run.evaluations,
        "finished": run.done,
        "objectives": metrics,
    }


def timing_document(run: Run) -> dict:
    """Where the run's time went (varies from run to run)."""
    timing = run.timing
    n = max(run.evaluations, 1)
    return {
        "evaluations": run.evaluations,
        "evaluator_seconds": timing.evaluator,
        "algorithm_seconds": timing.manager,
        "algorithm_overhead_per_evaluation_ms": 1000 * timing.manager / n,
        "overhead_fraction_of_evaluator_time": timing.manager / timing.evaluator
        if timing.evaluator
        else None,
        "evaluations_per_second": run.evaluations / timing.total if timing.total else None,
    }


def write_results(run: Run, with_figures: bool = True) -> list[Path]:
    """Write every result file of ``run`` (atomically, file by file); return their paths."""
    directory: RunDirectory = run.directory
    written: list[Path] = []
    for objective in OBJECTIVES:
        path = directory.repertoire(objective)
        write_json(path, repertoire_document(run.passive[objective], objective, run))
        written.append(path)
    archive = run.archive()
    if archive is not None:
        write_json(directory.archive, repertoire_document(archive, run.config.objectives[0], run))
        written.append(directory.archive)
    write_json(directory.summary, summary_document(run))
    write_json(directory.root / "timing.json", timing_document(run))
    written += [directory.summary, directory.root / "timing.json"]
    written += write_best_trees(run)
    if with_figures:
        written += write_figures(run)
        from .explorer import write_explorer

        written.append(write_explorer(directory.root))
    return written


def write_best_trees(run: Run) -> list[Path]:
    """The best tree of each evolved objective, simplified, in every format the behaviour-tree engine
    offers (text, indented, XML, DOT, SVG, PNG), and the original text. Any failure raises."""
    written = []
    directory = run.directory.best
    directory.mkdir(exist_ok=True)
    for objective in run.config.objectives:
        best = run.passive[objective].best()
        if best is None:
            continue
        tree = simplify(parse(best.tree))
        header = f"# best {objective} tree of {run.config.label}: fitness {best.value!r}, "
        header += f"evaluation {best.evaluation}; simplified from {parse(best.tree).size} to {tree.size} "
        header += "nodes "
        header += f"(the same motors on every tick; the tree as evolved is in {objective}.original.txt)\n"
        files = {
            "txt": to_text(tree) + "\n",
            "original.txt": best.tree + "\n",
            "indented.txt": header + to_indented(tree),
            "xml": to_xml(tree),
            "dot": to_dot(tree),
        }
        for suffix, text in files.items():
            path = directory / f"{objective}.{suffix}"
            write_atomic(path, text)
            written.append(path)
        for fmt in ("svg", "png"):
            written.append(Path(render(tree, directory / f"{objective}.{fmt}", fmt)))
    return written


def write_figures(run: Run) -> list[Path]:
    """Heatmaps of each evolved objective's grid, the histogram of every grid, the progress curves."""
    from . import figures  # matplotlib (about 1.5 s to import) only when figures are drawn

    folder = run.directory.figures
    written = []
    for objective in run.config.objectives:
        written.append(
            figures.heatmaps(
                run.passive[objective],
                f"{run.config.label} ({objective})",
                folder / f"heatmap_{objective}.png",
            )
        )
    rows = {o: {run.config.label: run.passive[o]} for o in run.config.objectives}
    written.append(figures.histograms(rows, folder / "histogram.png"))
    written.append(
        figures.progress(
            {run.config.label: run.directory.progress.read()}, folder / "progress.png", run.config.objectives
        )
    )
    return written
