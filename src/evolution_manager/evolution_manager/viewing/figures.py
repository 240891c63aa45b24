"""Figures in the style of the paper: grid heatmaps (fig. 7), fitness histograms (fig. 8), box plots
(figs. 4-6) and progress curves. Every function writes one PNG with matplotlib's Agg backend and returns
its path; none keeps state between calls."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from evolution_manager.evolution.archive import Repertoire
from evolution_manager.evolution.deap_trees import DESCRIPTORS, OBJECTIVES
from evolution_manager.files import writing
from evolution_manager.viewing.palette import carry_colour
from swarm_ros.safe_paths import make_folder, replace_file

_SAVE: dict[str, Any] = {"dpi": 110, "bbox_inches": "tight", "metadata": {"Software": None}}


def subplots(
    *grid: int,
    figsize: tuple[float, float],
    constrained_layout: bool = False,
    squeeze: bool = True,
    sharex: bool = False,
    sharey: bool = False,
) -> tuple[Figure, Any]:
    """A figure and its axes, as ``pyplot.subplots`` makes them, without pyplot (whose import costs half a
    second, and which keeps every figure until closed): the same pixels."""
    figure = Figure(figsize=figsize, layout="constrained" if constrained_layout else None)
    axes: Axes | np.ndarray = figure.subplots(*grid, squeeze=squeeze, sharex=sharex, sharey=sharey)
    return figure, axes


def _save(figure: Figure, path: Path) -> Path:
    path = Path(path)
    with writing(path):  # a link planted at the file or its folder is refused (swarm_ros.safe_paths)
        make_folder(path.parent)
        replace_file(path, lambda temporary: figure.savefig(temporary, **_SAVE))
    return path


def fitness_top(values: Iterable[float]) -> float:
    """The top of a fitness axis: 1 (the objectives in [0, 1]), or above it for foraging (deliveries per
    robot per trial) when a value exceeds 1, rounded up to a quarter."""
    largest = max(values, default=0.0)
    return 1.0 if largest <= 1.0 else math.ceil(largest * 4.0) / 4.0


def heatmaps(
    repertoire: Repertoire, title: str, path: Path, descriptors: Sequence[str] = DESCRIPTORS
) -> Path:
    """The 8 x 8 x 8 grid as eight 8 x 8 heatmaps (fig. 7): one panel per bin of the third descriptor
    (conditionality), the first (movement) across, the second (rotation) up, colour the best fitness in the
    bin (blank when empty) from 0 to ``fitness_top``."""
    best = np.full(repertoire.shape, np.nan)
    for index, value in repertoire.best_per_bin().items():
        best[index] = value
    top = fitness_top(repertoire.best_per_bin().values())
    figure, axes = subplots(2, 4, figsize=(12, 6.2), constrained_layout=True)
    image = None
    for k, axis in enumerate(axes.flat):
        image = axis.imshow(best[:, :, k].T, origin="lower", vmin=0.0, vmax=top, cmap="viridis")
        axis.set_title(f"{descriptors[2]} bin {k}", fontsize=9)
        axis.set_xticks(range(8))
        axis.set_yticks(range(8))
        axis.tick_params(labelsize=7)
        if k >= 4:
            axis.set_xlabel(descriptors[0], fontsize=8)
        if k % 4 == 0:
            axis.set_ylabel(descriptors[1], fontsize=8)
    assert image is not None  # eight panels were drawn
    figure.colorbar(image, ax=axes, shrink=0.8, label="best fitness in bin")
    figure.suptitle(f"{title}: coverage {repertoire.coverage:.3f}, QD score {repertoire.qd_score:.2f}")
    return _save(figure, path)


def histograms(rows: Mapping[str, Mapping[str, Repertoire]], path: Path) -> Path:
    """The best fitness of every filled bin of each repertoire (fig. 8, as the authors' analysis): one row
    per objective, one panel per algorithm (in the order given), each titled with the repertoire's size in
    filled bins. ``rows[objective][algorithm label]``."""
    objectives = list(rows)
    columns = max(len(row) for row in rows.values())
    figure, axes = subplots(
        len(objectives), columns, figsize=(3.6 * columns, 2.6 * len(objectives)), squeeze=False
    )
    for i, objective in enumerate(objectives):
        top = fitness_top(v for r in rows[objective].values() for v in r.best_per_bin().values())
        bins = np.linspace(0.0, top, 41)
        for j in range(columns):
            axis = axes[i][j]
            if j >= len(rows[objective]):
                axis.axis("off")
                continue
            label, repertoire = list(rows[objective].items())[j]
            values = list(repertoire.best_per_bin().values())
            axis.hist(values, bins=bins, color="tab:blue")
            axis.set_title(f"{objective}: {label}, {len(values)} solutions", fontsize=9)
            axis.set_xlim(0.0, top)
            axis.tick_params(labelsize=7)
            if i == len(objectives) - 1:
                axis.set_xlabel("fitness", fontsize=8)
    figure.tight_layout()
    return _save(figure, path)


def progress(
    curves: Mapping[str, Sequence[Mapping[str, str]]],
    path: Path,
    objectives: Sequence[str],
    heldout: Mapping[str, Mapping[str, tuple[float, float | None, float | None]]] | None = None,
) -> Path:
    """Best fitness, coverage and QD score against evaluations, one line per curve label and objective.
    Each curve is a list of progress rows (``evaluations``, ``best_<o>``, ``coverage_<o>``,
    ``qd_score_<o>``). ``heldout[label][objective]`` = (evaluations, held-out best fitness, held-out QD
    score) adds the held-out scores as hollow markers in the curve's colour."""
    metrics = ("best", "coverage", "qd_score")
    figure, axes = subplots(1, 3, figsize=(14, 3.8))
    for label, rows in curves.items():
        x = [float(r["evaluations"]) for r in rows]
        for axis, metric in zip(axes, metrics, strict=True):
            for objective in objectives:
                y = [
                    float(r[f"{metric}_{objective}"]) if r[f"{metric}_{objective}"] != "" else np.nan
                    for r in rows
                ]
                name = label if len(objectives) == 1 else f"{label} {objective}"
                (line,) = axis.plot(x, y, label=name, linewidth=1.2)
                held = (heldout or {}).get(label, {}).get(objective)
                value = None if held is None or metric == "coverage" else held[1 if metric == "best" else 2]
                if held is not None and value is not None:
                    axis.plot(
                        [held[0]],
                        [value],
                        marker="o",
                        markersize=7,
                        markerfacecolor="none",
                        color=line.get_color(),
                        linestyle="none",
                        label=f"{name} held-out",
                    )
    for axis, metric in zip(axes, metrics, strict=True):
        axis.set_xlabel("evaluations")
        axis.set_title(metric.replace("_", " "))
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    figure.tight_layout()
    return _save(figure, path)


BOX_COLUMNS = 3
"""Panels to a row of box plots, as the paper's figs. 4-6 have them: seven objectives side by side were
3,200 px wide, unreadable at page width."""


def boxes(samples: Mapping[str, Mapping[str, Sequence[float]]], metric: str, path: Path) -> Path:
    """Box plots of one metric (figs. 4-6): one panel per objective, one box per algorithm, at most
    ``BOX_COLUMNS`` panels to a row. ``samples[objective][algorithm label]`` is the metric over runs."""
    most = max(len(by_label) for by_label in samples.values())
    wide = most > 4  # many boxes (the foraging study's arms): a wider panel, labels slanted
    width = max(4.2, 0.8 * most) if wide else 4.2
    columns = min(BOX_COLUMNS, len(samples))
    rows = math.ceil(len(samples) / columns)
    figure, axes = subplots(rows, columns, figsize=(width * columns, 3.8 * rows), squeeze=False)
    for axis in axes.flat[len(samples) :]:
        axis.set_visible(False)  # the last row's empty places
    for axis, (objective, by_label) in zip(axes.flat, samples.items(), strict=False):
        labels = list(by_label)
        axis.boxplot([list(by_label[label]) for label in labels], tick_labels=labels)
        axis.set_title(objective)
        axis.set_ylabel(metric)
        axis.grid(alpha=0.3, axis="y")
        axis.tick_params(labelsize=8)
        if wide:
            for label in axis.get_xticklabels():
                label.set_rotation(30)
                label.set_horizontalalignment("right")
    figure.tight_layout()
    return _save(figure, path)


@dataclass(frozen=True)
class Band:
    """A metric over runs against evaluations: its median and quartiles at each point of ``evaluations``."""

    evaluations: Sequence[float]
    low: Sequence[float]
    """The first quartile."""
    median: Sequence[float]
    high: Sequence[float]
    """The third quartile."""
    runs: int


def progress_bands(bands: Mapping[str, Band], metric: str, path: Path, note: str = "") -> Path:
    """Small multiples, a panel per label (four to a row, axes shared): the label's median over runs as a
    line and its interquartile range as a band of the line's colour, every other label's median in grey for
    reference. ``note``: a line under the title."""
    columns = min(4, max(1, len(bands)))
    rows = max(1, math.ceil(len(bands) / columns))
    figure, axes = subplots(
        rows, columns, figsize=(3.6 * columns, 2.9 * rows + 0.6), squeeze=False, sharex=True, sharey=True
    )
    palette = [f"C{k}" for k in range(10) if k != 7]  # C7 is grey, the colour of the reference lines
    colours = [palette[k % len(palette)] for k in range(len(bands))]
    for k, (axis, (label, band)) in enumerate(zip(axes.flat, bands.items(), strict=False)):
        for name, reference in bands.items():
            if name != label:
                axis.plot(reference.evaluations, reference.median, color="0.75", linewidth=0.8, zorder=1)
        axis.fill_between(band.evaluations, band.low, band.high, color=colours[k], alpha=0.25, linewidth=0)
        axis.plot(band.evaluations, band.median, color=colours[k], linewidth=1.6, zorder=3)
        axis.set_title(f"{label} ({band.runs} runs)", fontsize=9)
        axis.grid(alpha=0.3)
        axis.tick_params(labelsize=8)
    for axis in list(axes.flat)[len(bands) :]:
        axis.set_visible(False)
    for axis in axes[-1]:
        axis.set_xlabel("evaluations", fontsize=8)
    for axis in axes[:, 0]:
        axis.set_ylabel(metric, fontsize=8)
    title = "median over runs, interquartile range shaded; the other arms' medians in grey"
    figure.suptitle(title + (f"\n{note}" if note else ""), fontsize=10)
    figure.tight_layout()
    return _save(figure, path)


def transfer_scatter(points: Mapping[str, Mapping[str, Sequence[tuple[float, float]]]], path: Path) -> Path:
    """One panel per objective: each run's best tree as (our score, ARGoS's score) on fresh scenarios, one
    marker per algorithm, and the diagonal where both simulators agree. ``points[objective][label]``."""
    markers = ("o", "s", "^", "D", "v")
    figure, axes = subplots(1, len(points), figsize=(4.2 * len(points), 4.0), squeeze=False)
    for axis, (objective, by_label) in zip(axes[0], points.items(), strict=True):
        values = [v for pairs in by_label.values() for pair in pairs for v in pair]
        low = min(values, default=0.0)
        high = max(values, default=1.0)
        pad = 0.05 * (high - low or 1.0)
        low, high = low - pad, high + pad
        axis.plot([low, high], [low, high], color="0.6", linewidth=1, zorder=0)
        for marker, (label, pairs) in zip(markers, by_label.items(), strict=False):
            if pairs:
                axis.scatter(
                    [p[0] for p in pairs], [p[1] for p in pairs], label=label, marker=marker, s=22, alpha=0.8
                )
        axis.set_xlim(low, high)
        axis.set_ylim(low, high)
        axis.set_aspect("equal")
        axis.set_title(objective)
        axis.set_xlabel("here (fresh scenarios)")
        axis.set_ylabel("ARGoS")
        axis.grid(alpha=0.3)
        axis.legend(fontsize=8, loc="upper left")
    figure.tight_layout()
    return _save(figure, path)


__all__ = [
    "OBJECTIVES",
    "Band",
    "boxes",
    "heatmaps",
    "histograms",
    "progress",
    "progress_bands",
    "transfer_scatter",
]


ROBOT_PANELS_PER_ROW = 4
"""Panels a row of :func:`robot_deliveries`' figure."""


def robot_deliveries(swarms: Mapping[str, np.ndarray], title: str, path: Path) -> Path:
    """Who delivers what: one panel per swarm (``swarms[label]``: robots x food kinds, each robot's mean
    deliveries of each kind per trial), one stacked bar per robot, a colour per kind (the animation's); at
    most four panels a row, so that many swarms still read at page width."""
    labels = list(swarms)
    columns = min(len(labels), ROBOT_PANELS_PER_ROW)
    rows = -(-len(labels) // columns)
    figure, axes = subplots(rows, columns, figsize=(3.6 * columns, 3.2 * rows), squeeze=False, sharey=True)
    for axis in axes.flat[len(labels) :]:
        axis.set_visible(False)
    top = max((float(v.sum(axis=1).max()) for v in swarms.values() if v.size), default=0.0)
    for axis, label in zip(axes.flat, labels, strict=False):
        values = np.asarray(swarms[label], dtype=float)
        robots = np.arange(values.shape[0])
        bottom = np.zeros(values.shape[0])
        for kind in range(values.shape[1]):
            colour = tuple(c / 255 for c in carry_colour(kind))
            axis.bar(robots, values[:, kind], bottom=bottom, color=colour, label=f"kind {kind + 1}")
            bottom += values[:, kind]
        axis.set_title(label, fontsize=9)
        axis.set_xticks(robots)
        axis.set_xlabel("robot")
        axis.set_ylim(0, max(top * 1.1, 0.05))
        axis.grid(alpha=0.3, axis="y")
    for row in axes:
        row[0].set_ylabel("deliveries per trial")
    axes[0][0].legend(fontsize=7)
    figure.suptitle(title, fontsize=10)
    figure.tight_layout()
    return _save(figure, path)
