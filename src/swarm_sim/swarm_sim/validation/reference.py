"""Validation against the authors' ARGoS simulation: our statistics beside theirs, a verdict per quantity.

A reference file is a TSV with one row per tree (as written by the ARGoS harness, see
``docs/validation/README.md``): ``tree``, then ``<q>_mean`` and ``<q>_sem`` for the quantities it measured
(of ``QUANTITIES``: the harness's 2023 build gives the paper's three objectives, its primitives build all six
primitives' objectives, its foraging build foraging, each with the three descriptors). Movement and rotation
are in the authors' raw units there, [-T, T] per trial for T ticks; they are mapped to [0, 1] as the model
does, (x + T) / 2T (standard errors / 2T), unless ``movement01_mean`` etc. are given. Trees in the authors'
syntax are read into ours (``bt_controller.language.authors``); a row ``nn: w1 ... w56`` is a neural
controller (``network_of_subject``).

Tolerance (``docs/model.md``, "validation"): our mean **agrees** with the reference when
``|ours - theirs| <= 3 * sqrt(2) * SE + 0.03``, SE being the reference's standard error; it is
**indistinguishable** when it agrees and, in addition, ``|z| <= 4`` with ``z = diff / sqrt(SE_ours^2 +
SE_theirs^2)``. Everything here is pure: no simulation, no files except through the functions that say so.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from bt_controller.interpreters import Network
from swarm_sim.errors import ReferenceFileError
from swarm_sim.model import VALUE_NAMES

QUANTITIES: tuple[str, ...] = VALUE_NAMES
"""The quantities of an evaluation, in the evaluator's order (the objectives, then the three descriptors)."""
RAW_DESCRIPTOR_HALF_RANGE = 40.0
"""Movement and rotation per trial lie in [-40, 40] in the authors' code for the primitives' 40 ticks (one
count per tick); [-200, 200] for the foraging trials' 200."""
TOLERANCE_SE = 3.0 * math.sqrt(2.0)
"""Multiple of the reference's standard error allowed between the means."""
TOLERANCE_ABSOLUTE = 0.03
"""Absolute slack added to the tolerance (model.md)."""
MAX_Z = 4.0
"""Largest |z| of a difference still called indistinguishable."""
RESOLUTION = 1e-6
"""The reference files print 6 decimals: a smaller difference is rounding (say, -26.6 / 80 computed two
ways), not a difference, and gets z = 0 even when both standard errors are 0."""

AGREES = "agrees"
INDISTINGUISHABLE = "indistinguishable"
OUTSIDE = "OUTSIDE"

__all__ = [
    "AGREES",
    "INDISTINGUISHABLE",
    "OUTSIDE",
    "Comparison",
    "Estimate",
    "ReferenceFileError",
    "compare",
    "estimate",
    "estimates",
    "network_of_subject",
    "read_multifood_reference",
    "read_reference",
    "render",
    "swarm_trees",
    "tsv_rows",
]


@dataclass(frozen=True)
class Estimate:
    """A mean and its standard error over ``n`` evaluations."""

    mean: float
    sem: float
    n: int


@dataclass(frozen=True)
class Comparison:
    """Our estimate of one quantity of one tree beside the reference's, and the verdict (``group``: the
    kind of trial, e.g. ``foraging``, when a report holds more than one)."""

    tree: str
    quantity: str
    ours: Estimate
    theirs: Estimate
    group: str = ""

    @property
    def diff(self) -> float:
        """Ours minus theirs."""
        return self.ours.mean - self.theirs.mean

    @property
    def tolerance(self) -> float:
        """The largest |diff| that agrees: 3 sqrt(2) SE_theirs + 0.03."""
        return TOLERANCE_SE * self.theirs.sem + TOLERANCE_ABSOLUTE

    @property
    def z(self) -> float:
        """diff / sqrt(SE_ours^2 + SE_theirs^2); 0 for a diff within ``RESOLUTION``, infinite for exact values
        (both SE 0) that differ by more."""
        if abs(self.diff) <= RESOLUTION:
            return 0.0
        scale = math.hypot(self.ours.sem, self.theirs.sem)
        if scale == 0.0:
            return math.copysign(math.inf, self.diff)
        return self.diff / scale

    @property
    def agrees(self) -> bool:
        """|diff| within the tolerance."""
        return abs(self.diff) <= self.tolerance

    @property
    def verdict(self) -> str:
        """``indistinguishable``, ``agrees`` (within tolerance but |z| > 4) or ``OUTSIDE``."""
        if not self.agrees:
            return OUTSIDE
        return INDISTINGUISHABLE if abs(self.z) <= MAX_Z else AGREES


def estimate(samples: Sequence[float]) -> Estimate:
    """Mean and standard error (sample standard deviation, ddof 1, over sqrt(n)) of at least two samples."""
    n = len(samples)
    if n < 2:
        raise ValueError(f"a standard error needs at least 2 samples, got {n}")
    if min(samples) == max(samples):  # exact: no rounding noise in the mean or a spurious tiny SE
        return Estimate(float(samples[0]), 0.0, n)
    mean = math.fsum(samples) / n
    variance = math.fsum((x - mean) ** 2 for x in samples) / (n - 1)
    return Estimate(mean, math.sqrt(variance / n), n)


def estimates(rows: Sequence[Sequence[float]], quantities: Sequence[str] = QUANTITIES) -> dict[str, Estimate]:
    """Per quantity, the estimate over evaluations given as rows of values (``quantities`` order: by default
    an evaluation's, ``QUANTITIES``)."""
    for row in rows:
        if len(row) != len(quantities):
            raise ValueError(f"expected {len(quantities)} values per evaluation, got {len(row)}")
    return {q: estimate([float(row[i]) for row in rows]) for i, q in enumerate(quantities)}


def tsv_rows(path: Path, what: str, error: type[Exception]) -> csv.DictReader:
    """The rows of the tab-separated file ``path`` (``what`` it should be, for the messages); ``error`` with
    one line naming the file when it cannot be read or is not UTF-8 text."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as problem:
        raise error(f"{path}: cannot read {what} ({problem.strerror or problem})") from None
    except UnicodeDecodeError as problem:
        raise error(f"{path}: not UTF-8 text (byte {problem.start}: {problem.reason})") from None
    return csv.DictReader(text.splitlines(), delimiter="\t")


def read_reference(path: Path, ticks: int = 40) -> dict[str, dict[str, Estimate]]:
    """The reference statistics of a TSV, per tree (file order) and each quantity it measured, descriptors
    mapped to [0, 1] (raw ones with trials of ``ticks`` ticks)."""
    reader = tsv_rows(path, "the reference", ReferenceFileError)
    columns = set(reader.fieldnames or ())
    measured = [q for q in QUANTITIES if f"{q}_mean" in columns or f"{q}_sem" in columns]
    descriptors = QUANTITIES[-3:]
    needed = {"tree"} | {f"{q}_{s}" for q in {*measured, *descriptors} for s in ("mean", "sem")}
    missing = sorted(needed - columns)
    if missing or len(measured) == len(descriptors):
        what = ", ".join(missing) if missing else "an objective's <q>_mean and <q>_sem"
        raise ReferenceFileError(f"{path}: not a reference statistics TSV: missing column(s) {what}")
    out: dict[str, dict[str, Estimate]] = {}
    for line, row in enumerate(reader, start=2):
        tree = (row["tree"] or "").strip()
        if not tree:
            raise ReferenceFileError(f"{path}:{line}: empty tree")
        if tree in out:
            raise ReferenceFileError(f"{path}:{line}: tree {tree!r} given twice")
        n = _number(path, line, row, "n_seeds", default=0.0)
        out[tree] = {q: _reference_estimate(path, line, row, q, int(n), ticks) for q in measured}
    if not out:
        raise ReferenceFileError(f"{path}: no trees in the reference")
    return out


MULTIFOOD_QUANTITIES: dict[str, str] = {
    "foraging": "foraging",
    "food1": "foraging1",
    "food2": "foraging2",
    "food3": "foraging3",
    "fitness": "foraging_biased",
}
"""The harness's multi-food columns (``--build multifood``) and our objective of each: deliveries of every
kind, of kinds 1-3, and their biased fitness (``foraging`` where no kind is preferred)."""

SWARM_PREFIX = "swarm:"
"""A reference row whose subject starts so is a heterogeneous swarm: a tree per robot, ``;`` between them."""


def swarm_trees(subject: str) -> tuple[str, ...] | None:
    """The robots' trees of a reference subject that is a swarm (``swarm: T1 ; T2 ; ...``), else None."""
    if not subject.startswith(SWARM_PREFIX):
        return None
    return tuple(tree.strip() for tree in subject[len(SWARM_PREFIX) :].split(";"))


NETWORK_PREFIX = "nn:"
"""A reference row whose subject starts so is a neural controller in the harness's form (``nn: w1 ... w56``:
the 56 weights of ``bt_controller.network`` in the authors' order, space-separated)."""


def network_of_subject(subject: str) -> Network | None:
    """The network of a reference subject in the harness's form (``nn: w1 ... w56``), else None;
    ValueError (one line) when the weights are not 56 finite numbers."""
    if not subject.startswith(NETWORK_PREFIX):
        return None
    weights = []
    for word in subject[len(NETWORK_PREFIX) :].split():
        try:
            weights.append(float(word))
        except ValueError:
            raise ValueError(f"network weight {word!r} is not a number") from None
    return Network(tuple(weights))


def read_multifood_reference(path: Path, ticks: int = 200) -> dict[str, dict[str, dict[str, Estimate]]]:
    """The statistics of a multi-food reference TSV (the harness's ``argos_stats_multifood.tsv``): per
    ``setting`` (the harness's configuration, ``key=value;...``, with ``;build=B`` added for a build other
    than ``multifood``), per tree or swarm (file order), our objective of each column of
    ``MULTIFOOD_QUANTITIES`` the file has, and the descriptors where the row measured them (their projects
    of ten slots; ``nan`` elsewhere), movement and rotation mapped from trials of the setting's ``trial_s``
    (``ticks`` ticks without one)."""
    reader = tsv_rows(path, "the reference", ReferenceFileError)
    columns = set(reader.fieldnames or ())
    measured = [q for q in MULTIFOOD_QUANTITIES if f"{q}_mean" in columns]
    missing = sorted({"tree", "setting", "foraging_mean", "foraging_sem"} - columns)
    if missing:
        raise ReferenceFileError(
            f"{path}: not a multi-food reference statistics TSV: missing column(s) {', '.join(missing)}"
        )
    out: dict[str, dict[str, dict[str, Estimate]]] = {}
    for line, row in enumerate(reader, start=2):
        subject, setting = (row["tree"] or "").strip(), (row["setting"] or "").strip()
        if not subject or not setting:
            raise ReferenceFileError(f"{path}:{line}: empty {'tree' if not subject else 'setting'}")
        build = (row.get("build") or "multifood").strip()
        if build != "multifood":
            setting += f";build={build}"
        by_subject = out.setdefault(setting, {})
        if subject in by_subject:
            raise ReferenceFileError(f"{path}:{line}: tree {subject!r} given twice for setting {setting!r}")
        n = int(_number(path, line, row, "n_seeds", default=0.0))
        by_subject[subject] = {}
        for column in measured:
            mean = _number(path, line, row, f"{column}_mean")
            sem = _number(path, line, row, f"{column}_sem")
            if sem < 0:
                raise ReferenceFileError(f"{path}:{line}: {column} standard error must be >= 0, got {sem}")
            by_subject[subject][MULTIFOOD_QUANTITIES[column]] = Estimate(mean, sem, n)
        seconds = dict(item.partition("=")[::2] for item in setting.split(";")).get("trial_s")
        try:
            row_ticks = ticks if seconds is None else round(2 * float(seconds))  # 2 ticks a second
        except ValueError:
            raise ReferenceFileError(f"{path}:{line}: trial_s must be a number, got {seconds!r}") from None
        for descriptor in QUANTITIES[-3:]:
            if row.get(f"{descriptor}_mean", "nan").strip().lower() not in ("nan", ""):
                by_subject[subject][descriptor] = _reference_estimate(
                    path, line, row, descriptor, n, row_ticks
                )
    if not out:
        raise ReferenceFileError(f"{path}: no trees in the reference")
    return out


def _number(path: Path, line: int, row: dict[str, str], column: str, default: float | None = None) -> float:
    text = row.get(column)
    if text is None or text == "":
        if default is not None:
            return default
        raise ReferenceFileError(f"{path}:{line}: empty {column}")
    try:
        value = float(text)
    except ValueError:
        raise ReferenceFileError(f"{path}:{line}: {column} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise ReferenceFileError(f"{path}:{line}: {column} must be finite, got {text!r}")
    return value


def _reference_estimate(
    path: Path, line: int, row: dict[str, str], quantity: str, n: int, ticks: int
) -> Estimate:
    if quantity in ("movement", "rotation"):
        if row.get(f"{quantity}01_mean"):
            mean = _number(path, line, row, f"{quantity}01_mean")
            sem = _number(path, line, row, f"{quantity}01_sem")
        else:
            raw_mean = _number(path, line, row, f"{quantity}_mean")
            mean = (raw_mean + ticks) / (2 * ticks)
            sem = _number(path, line, row, f"{quantity}_sem") / (2 * ticks)
    else:
        mean = _number(path, line, row, f"{quantity}_mean")
        sem = _number(path, line, row, f"{quantity}_sem")
    if sem < 0:
        raise ReferenceFileError(f"{path}:{line}: {quantity} standard error must be >= 0, got {sem}")
    return Estimate(mean, sem, n)


def compare(
    tree: str, ours: dict[str, Estimate], theirs: dict[str, Estimate], group: str = ""
) -> list[Comparison]:
    """One comparison per quantity the reference measured (``QUANTITIES`` order)."""
    return [Comparison(tree, q, ours[q], theirs[q], group) for q in QUANTITIES if q in theirs]


def _named(c: Comparison) -> str:
    return f"[{c.group}] {c.tree}" if c.group else c.tree


def _shown(subject: str) -> str:
    """A subject as the report shows it: a network's 56 weights cut to the first three and the last (the
    reference file holds them all)."""
    if network_of_subject(subject) is None:
        return subject
    weights = subject[len(NETWORK_PREFIX) :].split()
    return f"{NETWORK_PREFIX} {' '.join(weights[:3])} … {weights[-1]}"


def _code(name: str) -> str:
    """A tree's name as markdown: the tree as code, its group (``[foraging] ``) before it as text."""
    if name.startswith("["):
        group, tree = name.split("] ", 1)
        return f"{group}] `{_shown(tree)}`"
    return f"`{_shown(name)}`"


def _fmt(e: Estimate) -> str:
    return f"{e.mean:.4f} ± {e.sem:.4f}"


def _z(c: Comparison) -> str:
    if math.isinf(c.z):
        return "+inf" if c.z > 0 else "-inf"
    return f"{c.z:+.1f}" if abs(c.z) < 1000 else f"{c.z:+.1e}"


_MARK = {INDISTINGUISHABLE: "✓", AGREES: "≈", OUTSIDE: "✗"}


def render(
    comparisons: Sequence[Comparison],
    header: Iterable[str],
    notes: str | None = None,
) -> str:
    """The markdown report: ``header`` lines, a summary, one verdict grid (a column per quantity any tree
    was compared on, ``-`` where a tree was not), one table per tree, ``notes``. A tree is named with its
    group, when it has one (``[foraging] forward``)."""
    trees = list(dict.fromkeys(_named(c) for c in comparisons))
    by_tree = {t: [c for c in comparisons if _named(c) == t] for t in trees}
    columns = [q for q in QUANTITIES if any(c.quantity == q for c in comparisons)]
    total = len(comparisons)
    agreeing = sum(c.agrees for c in comparisons)
    same = sum(c.verdict == INDISTINGUISHABLE for c in comparisons)
    lines = [*header, ""]
    lines += [
        f"**{agreeing} of {total}** quantities over {len(trees)} trees agree with ARGoS within tolerance; "
        f"**{same} of {total}** are also statistically indistinguishable (|z| <= {MAX_Z:g}).",
        "",
        f"Verdicts: {_MARK[INDISTINGUISHABLE]} indistinguishable, {_MARK[AGREES]} agrees (within tolerance, "
        f"|z| > {MAX_Z:g}), {_MARK[OUTSIDE]} outside tolerance.",
        "",
        "| # | tree | " + " | ".join(columns) + " |",
        "|---|---|" + "---|" * len(columns),
    ]
    for number, tree in enumerate(trees, start=1):
        verdicts = {c.quantity: _MARK[c.verdict] for c in by_tree[tree]}
        marks = " | ".join(verdicts.get(q, "-") for q in columns)
        lines.append(f"| {number} | {_code(tree)} | {marks} |")
    lines.append("")
    for number, tree in enumerate(trees, start=1):
        lines += [
            f"### {number}. {_code(tree)}",
            "",
            "| quantity | ours (mean ± SE) | ARGoS (mean ± SE) | diff | tolerance | z | verdict |",
            "|---|---|---|---|---|---|---|",
        ]
        for c in by_tree[tree]:
            lines.append(
                f"| {c.quantity} | {_fmt(c.ours)} | {_fmt(c.theirs)} | {c.diff:+.4f} | {c.tolerance:.4f} | "
                f"{_z(c)} | {c.verdict} |"
            )
        lines.append("")
    outside = [c for c in comparisons if c.verdict != INDISTINGUISHABLE]
    lines += ["## Quantities not indistinguishable", ""]
    if outside:
        lines += [
            f"- {_code(_named(c))} {c.quantity}: {c.verdict}, diff {c.diff:+.4f} "
            f"(tolerance {c.tolerance:.4f}), z {_z(c)}"
            for c in outside
        ]
    else:
        lines.append("None.")
    lines.append("")
    if notes:
        lines += [notes.rstrip(), ""]
    return "\n".join(lines)
