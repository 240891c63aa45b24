"""``ws/run swarm_sim validate``: evaluate every reference tree here and write the validation report.

    validate --reference docs/validation/argos_stats.tsv [--reference MORE.tsv] [--profile paper]
             [--seeds 20] [--trials 10] [--notes docs/validation/notes.md] --out docs/validation.md
             [--foraging-reference docs/validation/argos_stats_foraging.tsv] [--library PRIMITIVES.json]

Each tree of the reference files is evaluated with seeds 1..N (one evaluation of ``--trials`` trials per seed,
all in one batch); our mean and standard error of each quantity the reference measured are set beside the
reference's with a verdict (``swarm_sim.validation``). ``--reference`` files are measured in the primitives'
20 s trials, ``--foraging-reference`` files in the 2024 foraging trials (100 s; their trees are labelled
``[foraging]``); trees in the authors' syntax are read into ours (``bt_controller.authors``), and a tree may
name the primitives of ``--library``. ``--notes`` is markdown appended as it is (the explanations of
what is outside tolerance, kept in the repository so that regenerating keeps them). ``--tsv`` also writes our
statistics in the reference's format. Bad input: one line on stderr, exit status 2; nothing is written then.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Sequence
from dataclasses import fields, replace
from pathlib import Path
from typing import NoReturn

from bt_controller.authors import from_authors, is_authors_syntax
from bt_controller.library import Library
from swarm_sim import validation
from swarm_sim.cli import library_option
from swarm_sim.config import DEFAULT, TASKS, Config
from swarm_sim.errors import UsageError
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, check_request

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="validate", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--reference", type=Path, action="append", required=True, help="reference statistics TSV (repeatable)"
    )
    parser.add_argument(
        "--foraging-reference",
        type=Path,
        action="append",
        default=[],
        help="reference statistics TSV of foraging trials (repeatable)",
    )
    parser.add_argument("--library", help="a primitive library (JSON) whose names the reference trees use")
    parser.add_argument("--profile", help="model profile (default: the model's default)")
    parser.add_argument("--seeds", type=int, default=20, help="evaluations per tree, seeds 1..N (default 20)")
    parser.add_argument("--trials", type=int, default=10, help="trials per evaluation (default 10)")
    parser.add_argument("--notes", type=Path, help="markdown appended to the report")
    parser.add_argument("--tsv", type=Path, help="also write our statistics as a TSV")
    parser.add_argument("--out", type=Path, required=True, help="the markdown report to write")
    return parser


def model_config(profile: str | None) -> Config:
    """The model's configuration for ``profile`` (None: the default)."""
    if profile is None:
        return DEFAULT
    if "profile" not in {f.name for f in fields(Config)}:
        raise UsageError(f"--profile {profile}: this model has no profiles")
    try:
        return Config(profile=profile)
    except ValueError as error:
        raise UsageError(f"--profile: {error}") from None


def ours(tree: str) -> str:
    """A reference tree in our syntax (the authors' read into ours, ``bt_controller.authors``)."""
    return from_authors(tree) if is_authors_syntax(tree) else tree


def our_estimates(
    trees: Sequence[str], seeds: int, trials: int, config: Config, library: Library | None = None
) -> dict[str, dict[str, validation.Estimate]]:
    """Per tree (a reference's text), our estimates over seeds 1..``seeds`` (one batch)."""
    requests = [EvaluationRequest(ours(tree), seed, trials) for tree in trees for seed in range(1, seeds + 1)]
    results = BatchEvaluator(config, library=library).evaluate(requests)
    out = {}
    for index, tree in enumerate(trees):
        rows = []
        for result in results[index * seeds : (index + 1) * seeds]:
            if result.error is not None:
                raise UsageError(f"tree {tree!r}: {result.error}")
            assert result.fitness is not None and result.descriptors is not None
            rows.append(result.fitness + result.descriptors)
        out[tree] = validation.estimates(rows)
    return out


def stats_tsv(estimates: dict[str, dict[str, validation.Estimate]], ticks: int = 40) -> str:
    """Our statistics in the reference's column layout (movement and rotation already in [0, 1] there as
    ``movement01``/``rotation01``; the raw columns are mapped back to [-ticks, ticks])."""
    half = float(ticks)
    header = ["tree"]
    for q in validation.QUANTITIES:
        header += [f"{q}_mean", f"{q}_sem"]
    header += ["movement01_mean", "movement01_sem", "rotation01_mean", "rotation01_sem", "n_seeds"]
    lines = ["\t".join(header)]
    for tree, by_q in estimates.items():
        cells = [tree]
        for q in validation.QUANTITIES:
            e = by_q[q]
            if q in ("movement", "rotation"):
                cells += [f"{e.mean * 2 * half - half:.6f}", f"{e.sem * 2 * half:.6f}"]
            else:
                cells += [f"{e.mean:.6f}", f"{e.sem:.6f}"]
        for q in ("movement", "rotation"):
            cells += [f"{by_q[q].mean:.6f}", f"{by_q[q].sem:.6f}"]
        cells.append(str(by_q["density"].n))
        lines.append("\t".join(cells))
    return "\n".join(lines) + "\n"


def run(argv: Sequence[str]) -> tuple[argparse.Namespace, str, str]:
    """Parse ``argv`` and evaluate: (options, report markdown, our statistics TSV). Raise UsageError."""
    args = _parser().parse_args(argv)
    if not 2 <= args.seeds <= 10_000:
        raise UsageError(f"--seeds must be in [2, 10000] (a standard error needs 2), got {args.seeds}")
    if not 1 <= args.trials <= 10_000:
        raise UsageError(f"--trials must be in [1, 10000], got {args.trials}")
    config = model_config(args.profile)
    library = library_option(args.library)
    foraging = replace(config, ticks=TASKS["foraging"])
    comparisons: list[validation.Comparison] = []
    tables: list[str] = []
    trees = 0
    groups = (("", config, args.reference), ("foraging", foraging, args.foraging_reference))
    for group, world, paths in groups:
        references = _references(paths, args.trials, world.ticks, library)
        if not references:
            continue
        trees += len(references)
        estimates = our_estimates(list(references), args.seeds, args.trials, world, library)
        for tree, stats in references.items():
            comparisons += validation.compare(tree, estimates[tree], stats, group)
        labelled = {f"[{group}] {t}" if group else t: e for t, e in estimates.items()}
        tables.append(stats_tsv(labelled, world.ticks))
    notes = None
    if args.notes is not None:
        try:
            notes = args.notes.read_text()
        except OSError as error:
            raise UsageError(f"--notes {args.notes}: {error.strerror or error}") from None
    print(f"validate: {trees} trees x {args.seeds} seeds x {args.trials} trials", file=sys.stderr)
    profile = getattr(config, "profile", None)
    command = "ws/run swarm_sim validate " + shlex.join(argv)
    tolerance = f"3 sqrt(2) SE_ARGoS + {validation.TOLERANCE_ABSOLUTE}"
    z_rule = f"|z| <= {validation.MAX_Z:g}, z = diff / sqrt(SE_ours² + SE_ARGoS²)"
    header = [
        "# Validation against the authors' ARGoS simulation",
        "",
        f"Generated by `{command}`; do not edit by hand (explanations live in the `--notes` file).",
        "",
        f"- Model: profile `{profile or 'none (this model has no profiles)'}`. Ours: mean ± standard error "
        f"over {args.seeds} evaluations per tree (seeds 1-{args.seeds}, {args.trials} trials each).",
        f"- ARGoS: {', '.join(f'`{p}`' for p in [*args.reference, *args.foraging_reference])} (mean ± "
        "standard error over its seeds; how they were measured: `docs/validation/README.md`). Movement and "
        "rotation mapped to [0, 1] as (x + T) / 2T for T ticks per trial (40; 200 in the `[foraging]` trees' "
        "100 s trials)" + (f"; primitives' names from `{args.library}`." if args.library else "."),
        f"- Tolerance (`docs/model.md`): agrees when |diff| <= {tolerance}; indistinguishable when it also "
        f"has {z_rule}.",
    ]
    tsv = tables[0] + "".join(t.split("\n", 1)[1] for t in tables[1:])
    return args, validation.render(comparisons, header, notes), tsv


def _references(
    paths: Sequence[Path], trials: int, ticks: int, library: Library | None
) -> dict[str, dict[str, validation.Estimate]]:
    """The reference statistics of ``paths`` per tree (a tree in two files: the first file's), every tree
    checked; UsageError naming the file and the problem."""
    references: dict[str, dict[str, validation.Estimate]] = {}
    for path in paths:
        try:
            stats_by_tree = validation.read_reference(path, ticks)
        except validation.ReferenceFileError as error:
            raise UsageError(str(error)) from None
        for tree, stats in stats_by_tree.items():
            try:
                check_request(EvaluationRequest(ours(tree), 1, trials), library=library)
            except ValueError as error:
                raise UsageError(f"{path}: tree {tree!r}: {error}") from None
            references.setdefault(tree, stats)
    return references


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point of ``validate``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args, report, tsv = run(argv)
        args.out.write_text(report)
        if args.tsv is not None:
            args.tsv.write_text(tsv)
    except UsageError as error:
        print(f"validate: error: {' '.join(str(error).split())}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:
        print(f"validate: error: cannot write the report: {error}", file=sys.stderr)
        return EXIT_USAGE
    print(f"validate: wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
