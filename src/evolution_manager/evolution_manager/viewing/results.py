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
    the best tree of each evolved objective, simplified (``bt_controller.language.simplify``: the same motors
    on every tick), as text, an indented view, BehaviorTree.CPP XML, Graphviz DOT, an SVG and a PNG drawing,
    and the tree as evolved in ``<objective>.original.txt``; a format that cannot be written is an error;
``explorer.html``
    the repertoire explorer (``evolution_manager.viewing.explorer``), one self-contained page.

Trees are shown to people simplified, with the original kept: every item of a repertoire file has ``tree``
(as evolved) and ``simplified``; the summary has ``best_tree`` and ``best_tree_simplified``. With a primitive
library, a simplified tree names each primitive left whole (``Library.fold``); the drawings show them
expanded. The repertoires and the summary cover the run's ``grids`` (its task's objectives and the evolved
ones).

This module only writes: the held-out scores and the simplified trees it shows are computed by the evolution
wing (``evolution.run_results``) and handed to it; it evaluates and simplifies nothing.
"""

from __future__ import annotations

from pathlib import Path

from bt_controller.language import to_dot, to_indented, to_xml
from bt_controller.tools import render
from evolution_manager.evolution.archive import Repertoire
from evolution_manager.evolution.descriptor_sets import descriptor_set
from evolution_manager.evolution.run import Run, RunDirectory
from evolution_manager.evolution.run_results import RunResults
from evolution_manager.files import write_atomic, write_json, writing
from evolution_manager.viewing.explorer import write_explorer
from swarm_ros.safe_paths import make_folder


def repertoire_document(repertoire: Repertoire, objective: str, run: Run, shown: dict[str, str]) -> dict:
    """A repertoire as the JSON document of ``repertoire_<objective>.json``; ``shown``: each tree's shown
    form (``RunResults.shown``)."""
    best = repertoire.best()
    return {
        "objective": objective,
        "algorithm": run.config.algorithm,
        "run": run.config.label,
        "seed": run.config.seed,
        "evaluations": run.evaluations,
        "shape": list(repertoire.shape),
        "items_per_bin": repertoire.items_per_bin,
        "descriptors": list(descriptor_set(run.config.descriptors).names),
        "coverage": repertoire.coverage,
        "qd_score": repertoire.qd_score,
        "best_fitness": best.value if best else None,
        "repertoire_size": repertoire.filled_bins,
        "size": len(repertoire),
        "items": [
            {
                "bin": list(item.bin),
                "tree": item.tree,
                "simplified": shown[item.tree],
                "fitness": item.fitness,
                "descriptors": list(item.descriptors),
                "evaluation": item.evaluation,
            }
            for item in repertoire.items()
        ],
    }


def summary_document(run: Run, results: RunResults) -> dict:
    """The deterministic summary of a run (no timings)."""
    heldout = results.heldout
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
            "best_tree_simplified": results.shown[best[0]] if best else None,
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


def write_results(run: Run, results: RunResults, with_figures: bool = True) -> list[Path]:
    """Write every result file of ``run`` (atomically, file by file) from what ``results`` computed
    (``evolution.run_results``); return their paths (``heldout.json`` first when it was scored for them)."""
    directory: RunDirectory = run.directory
    written: list[Path] = [directory.heldout] if results.heldout_scored else []
    for objective in run.config.grids:
        path = directory.repertoire(objective)
        write_json(path, repertoire_document(run.repertoire(objective), objective, run, results.shown))
        written.append(path)
    archive = run.archive()
    if archive is not None:
        document = repertoire_document(archive, run.config.objectives[0], run, results.shown)
        write_json(directory.archive, document)
        written.append(directory.archive)
    write_json(directory.summary, summary_document(run, results))
    write_json(directory.root / "timing.json", timing_document(run))
    written += [directory.summary, directory.root / "timing.json"]
    written += write_best_trees(run, results)
    if with_figures:
        written += write_figures(run, results.heldout)
        written.append(write_explorer(directory.root))
    return written


def write_best_trees(run: Run, results: RunResults) -> list[Path]:
    """The best tree of each evolved objective, simplified, in every format the behaviour-tree engine
    offers (text, indented, XML, DOT, SVG, PNG), and the original text. Any failure raises."""
    written = []
    directory = run.directory.best
    with writing(directory):  # a link planted in the run folder is refused, never followed
        make_folder(directory, run.directory.root)
    for best in results.best_trees:
        objective, tree = best.objective, best.shown
        header = f"# best {objective} tree of {run.config.label}: fitness {best.fitness!r}, "
        header += f"evaluation {best.evaluation}; simplified from {best.original.size} to {tree.size} "
        header += "nodes "
        header += f"(the same motors on every tick; the tree as evolved is in {objective}.original.txt)\n"
        files = {
            "txt": best.shown_text + "\n",
            "original.txt": best.text + "\n",
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
    # matplotlib (about 1.5 s to import) only when figures are drawn
    from evolution_manager.viewing import figures

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
                descriptor_set(run.config.descriptors).names,
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
