"""What a finished run leaves for a person to open: repertoires, summary, figures and the best trees.

``repertoire_<objective>.json``
    the repertoire of that objective (``Run.repertoire``: MAP-Elites' archive, GP's one-per-bin grid of
    generations 1 onwards, else the passive grid): bin, tree text, fitness, descriptors and evaluation index
    of every tree it holds (MAP-Elites' archive is also in ``archive.json``);
``summary.json``
    configuration, evaluations, simulations and simulations saved (fixed scenarios), and under
    ``objectives`` per objective the best fitness and tree, coverage, QD score (/ 512), repertoire size
    (filled bins) and items stored, with the held-out best fitness and QD score of ``heldout.json``
    (deterministic: same seed, same file);
``timing.json``
    wall-clock seconds in the evaluator and in the algorithm's own work, evaluations per second;
``figures/``
    ``heatmap_<objective>.png`` (fig. 7), ``histogram.png`` (fig. 8), ``progress.png``;
``best/<objective>.*``
    the best tree of each evolved objective, simplified (``bt_controller.simplify``: the same motors on every
    tick), as text, an indented view, BehaviorTree.CPP XML, Graphviz DOT, an SVG and a PNG drawing, and the
    tree as evolved in ``<objective>.original.txt``; a format that cannot be written is an error;
``explorer.html``
    the repertoire explorer (``evolution_manager.viewing.explorer``), one self-contained page.

Trees are shown to people simplified, with the original kept: every item of a repertoire file has ``tree``
(as evolved) and ``simplified``; the summary has ``best_tree`` and ``best_tree_simplified``. With a primitive
library, a simplified tree names each primitive left whole (``Library.fold``); the drawings show them
expanded. The repertoires and the summary cover the run's ``grids`` (its task's objectives and the evolved
ones).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from bt_controller.formats import to_dot, to_xml
from bt_controller.render import render
from bt_controller.tree import parse, to_indented, to_text
from evolution_manager.evolution.archive import Repertoire
from evolution_manager.evolution.deap_trees import DESCRIPTORS
from evolution_manager.evolution.run import Run, RunDirectory
from evolution_manager.files import write_atomic, write_json, writing
from evolution_manager.viewing.explorer import write_explorer
from evolution_manager.viewing.shown_trees import simplified, simplified_tree
from swarm_ros.safe_paths import make_folder

if TYPE_CHECKING:  # the simulator (numba) loads only when held-out scores are computed
    from swarm_sim.evaluation import Evaluator


def shown_form(run: Run, tree: str) -> str:
    """``simplified(tree, run.library)``; without a library that is the run's clone key, which the run
    has mostly computed already (``run.forms``)."""
    return run.forms(tree) if run.library is None else simplified(tree, run.library)


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
        "repertoire_size": repertoire.filled_bins,
        "size": len(repertoire),
        "items": [
            {
                "bin": list(item.bin),
                "tree": item.tree,
                "simplified": shown_form(run, item.tree),
                "fitness": item.fitness,
                "descriptors": list(item.descriptors),
                "evaluation": item.evaluation,
            }
            for item in repertoire.items()
        ],
    }


def summary_document(run: Run, heldout: dict | None = None) -> dict:
    """The deterministic summary of a run (no timings); ``heldout`` is the document of ``heldout.json``."""
    metrics = {}
    for objective in run.config.grids:
        grid = run.repertoire(objective)
        best = run.best(objective)
        held = (heldout or {}).get("objectives", {}).get(objective, {})
        metrics[objective] = {
            "evolved": objective in run.config.objectives,
            "best_fitness": best[1] if best else None,
            "heldout_best_fitness": held.get("heldout_best_fitness"),
            "best_tree": best[0] if best else None,
            "best_tree_simplified": shown_form(run, best[0]) if best else None,
            "best_descriptors": list(best[2]) if best else None,
            "best_evaluation": run.first_evaluation(best[0]) if best else None,
            "coverage": grid.coverage,
            "qd_score": grid.qd_score,
            "heldout_qd_score": held.get("heldout_qd_score"),
            "repertoire_size": grid.filled_bins,
            "items": len(grid),
            "items_per_bin": grid.items_per_bin,
        }
    return {
        "run": run.config.label,
        "config": run.config.to_json(),
        "evaluations": run.evaluations,
        "individuals_produced": run.algorithm.produced,
        "simulations": run.simulations,
        "simulations_saved": run.simulations_saved,
        "finished": run.done,
        "heldout": None
        if heldout is None
        else {k: heldout[k] for k in ("seeds", "evaluations_per_tree", "trials", "trees")},
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


def write_results(run: Run, with_figures: bool = True, evaluator: Evaluator | None = None) -> list[Path]:
    """Write every result file of ``run`` (atomically, file by file); return their paths.

    With an ``evaluator``, a finished run's repertoires are first re-scored on held-out scenarios
    (``evolution_manager.evolution.heldout``, ``heldout.json``); without one, an existing ``heldout.json``
    of the run is used."""
    from evolution_manager.evolution.heldout import heldout_path, score_heldout

    directory: RunDirectory = run.directory
    written: list[Path] = []
    heldout = None
    if evaluator is not None and run.done:
        heldout = score_heldout(run, evaluator)
        written.append(heldout_path(run))
    elif heldout_path(run).exists():
        from evolution_manager.files import read_json

        document = read_json(heldout_path(run))
        if isinstance(document, dict) and document.get("config") == run.config.to_json():
            heldout = document
    for objective in run.config.grids:
        path = directory.repertoire(objective)
        write_json(path, repertoire_document(run.repertoire(objective), objective, run))
        written.append(path)
    archive = run.archive()
    if archive is not None:
        write_json(directory.archive, repertoire_document(archive, run.config.objectives[0], run))
        written.append(directory.archive)
    write_json(directory.summary, summary_document(run, heldout))
    write_json(directory.root / "timing.json", timing_document(run))
    written += [directory.summary, directory.root / "timing.json"]
    written += write_best_trees(run)
    if with_figures:
        written += write_figures(run, heldout)
        written.append(write_explorer(directory.root))
    return written


def write_best_trees(run: Run) -> list[Path]:
    """The best tree of each evolved objective, simplified, in every format the behaviour-tree engine
    offers (text, indented, XML, DOT, SVG, PNG), and the original text. Any failure raises."""
    written = []
    directory = run.directory.best
    with writing(directory):  # a link planted in the run folder is refused, never followed
        make_folder(directory, run.directory.root)
    for objective in run.config.objectives:
        best = run.best(objective)
        if best is None:
            continue
        text, value, _ = best
        original = parse(text, library=run.library)
        tree = simplified_tree(original, run.library)
        header = f"# best {objective} tree of {run.config.label}: fitness {value!r}, "
        header += f"evaluation {run.first_evaluation(text)}; simplified from {original.size} to {tree.size} "
        header += "nodes "
        header += f"(the same motors on every tick; the tree as evolved is in {objective}.original.txt)\n"
        files = {
            "txt": (to_text(tree) if run.library is None else run.library.fold(tree)) + "\n",
            "original.txt": text + "\n",
            "indented.txt": header + to_indented(tree),
            "xml": to_xml(tree),
            "dot": to_dot(tree),
        }
        for suffix, text in files.items():
            path = directory / f"{objective}.{suffix}"
            write_atomic(path, text)
            written.append(path)
        for fmt in ("svg", "png"):
            name_of = None if run.library is None else run.library.shown_name_of  # primitives by name
            with writing(directory / f"{objective}.{fmt}"):
                written.append(Path(render(tree, directory / f"{objective}.{fmt}", fmt, name_of)))
    return written


def write_figures(run: Run, heldout: dict | None = None) -> list[Path]:
    """Heatmaps of each evolved objective's grid, the histogram of every grid, the progress curves (with
    the held-out scores as markers at the end, when there are any)."""
    from evolution_manager.viewing import (
        figures,  # matplotlib (about 1.5 s to import) only when figures are drawn
    )

    folder = run.directory.figures
    with writing(folder):  # a link planted in the run folder is refused, never followed
        make_folder(folder, run.directory.root)
    written = []
    for objective in run.config.objectives:
        written.append(
            figures.heatmaps(
                run.repertoire(objective),
                f"{run.config.label} ({objective})",
                folder / f"heatmap_{objective}.png",
            )
        )
    rows = {o: {run.config.label: run.repertoire(o)} for o in run.config.objectives}
    written.append(figures.histograms(rows, folder / "histogram.png"))
    final = None
    if heldout is not None:
        final = {
            run.config.label: {
                o: (run.evaluations, v["heldout_best_fitness"], v["heldout_qd_score"])
                for o, v in heldout["objectives"].items()
            }
        }
    written.append(
        figures.progress(
            {run.config.label: run.directory.progress.read()},
            folder / "progress.png",
            run.config.objectives,
            heldout=final,
        )
    )
    return written
