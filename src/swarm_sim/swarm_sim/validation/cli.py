"""``ws/run swarm_sim validate``: compare this model with the authors' ARGoS simulation.

    validate --reference docs/validation/argos_stats.tsv [--reference MORE.tsv] [--profile paper]
             [--seeds 20] [--trials 10] [--notes docs/validation/notes.md] [--transfer-table T.tsv]
             [--foraging-reference docs/validation/argos_stats_foraging.tsv] [--library PRIMITIVES.json]
             [--multifood-reference docs/validation/argos_stats_multifood.tsv] --out docs/validation.md
    validate --transfer RUN_DIR [RUN_DIR ...] [--per-run 4] [--evaluations 20] [--seeds 1-20]
             [--tree TREE ...] [--argos-eval argos_eval.py] [--argos-raw RAW.tsv] --out T.md [--tsv T.tsv]
    (either mode) [--force]: replace a report or table that exists

Reference mode: each tree of the reference files (ARGoS statistics measured by the harness) is evaluated
with seeds 1..N (one evaluation of ``--trials`` trials per seed, all in one batch); our mean and standard
error of each quantity the reference measured are set beside the reference's with a verdict
(``swarm_sim.validation.reference``). ``--reference`` files are measured in the primitives' 20 s trials,
``--foraging-reference`` files in the 2024 foraging trials (100 s; their trees are labelled ``[foraging]``),
``--multifood-reference`` files in the 2026 code's multi-food settings (a ``setting`` column per row, read
as the task of that arena, ``multifood_task``; rows labelled with the task's name; a row may be a swarm,
``swarm: T1 ; T2 ; ...``, one tree per robot); trees in the authors' syntax are read into ours
(``bt_controller.language.authors``), and a tree may name the primitives of ``--library``. ``--notes`` is
markdown appended as it is (the explanations of what is outside tolerance, kept in the repository so that
regenerating keeps them); ``--transfer-table`` adds the summary of a transfer table. ``--tsv`` also writes our
statistics in the reference's format.

Transfer mode (``swarm_sim.validation.transfer``): trees picked from evolution run directories of the
primitives' task without a library (each evolved grid's best and ``--per-run`` more by farthest-point sampling
of the grid, plus any ``--tree``) are evaluated here with ``--evaluations`` fresh seeds (1..N, less any run's
own scenario seed) and in ARGoS with ``--seeds`` through the harness's driver (``--argos-eval`` or
``$ARGOS_EVAL``); its raw rows go to ``--argos-raw`` (default: the report's name with ``_argos_raw.tsv``),
which is also read back as a cache. Writes the report (markdown) and the table (``--tsv``, default the
report's name with ``.tsv``).

Bad input, or an ARGoS build that is not there when rows are missing: one line on stderr, exit status 2;
nothing is written then (but the raw rows ARGoS produced). The report and the table follow the workspace's
rule for outputs (``swarm_ros.safe_paths``): one that exists is refused unless ``--force`` (regenerating
``docs/validation.md`` in place takes it), a symbolic link, a folder or a place under a file always, all
before anything is evaluated; ``--argos-raw``, a cache read and appended, is refused only as a link. The
command a report names as its maker leaves ``--force`` out: the same inputs give the same report.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import fields, replace
from pathlib import Path
from typing import NoReturn

from bt_controller.interpreters import network_text
from bt_controller.language import Library, from_authors, is_authors_syntax, library_option
from swarm_ros.safe_paths import check_output, refuse_links, replace_file
from swarm_sim.errors import ConfigError, UsageError
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, SwarmRequest, check_request
from swarm_sim.model import DEFAULT, Config, of_trees
from swarm_sim.tasks import FORAGING, FORAGING_2026, TaskSpec, Trials, arena_task
from swarm_sim.validation import reference as validation
from swarm_sim.validation import transfer

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="validate", description=__doc__.split("\n")[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--reference", type=Path, action="append", help="reference statistics TSV (repeatable)")
    mode.add_argument("--transfer", type=Path, nargs="+", metavar="RUN_DIR", help="evolution run directories")
    parser.add_argument(
        "--foraging-reference",
        type=Path,
        action="append",
        default=[],
        help="reference: statistics TSV of foraging trials (repeatable)",
    )
    parser.add_argument(
        "--multifood-reference",
        type=Path,
        action="append",
        default=[],
        help="reference: multi-food statistics TSV of the harness's 2026 build (setting per row; repeatable)",
    )
    parser.add_argument("--library", help="reference: a primitive library (JSON) whose names the trees use")
    parser.add_argument("--profile", help="model profile (default: the model's default)")
    parser.add_argument(
        "--seeds",
        help="reference: our seeds (N: 1..N; default 20); transfer: ARGoS's seeds (default 1-20); "
        "N, A-B or a comma-separated list",
    )
    parser.add_argument("--trials", type=int, default=10, help="trials per evaluation (default 10)")
    parser.add_argument("--notes", type=Path, help="markdown appended to the report")
    parser.add_argument("--transfer-table", type=Path, help="reference: add the summary of this transfer TSV")
    parser.add_argument(
        "--per-run", type=int, default=4, help="transfer: trees per grid besides its best (4)"
    )
    parser.add_argument("--evaluations", type=int, default=20, help="transfer: our evaluations per tree (20)")
    parser.add_argument("--tree", action="append", default=[], help="transfer: also check this tree")
    parser.add_argument("--argos-eval", help="transfer: the ARGoS harness's argos_eval.py ($ARGOS_EVAL)")
    parser.add_argument("--argos-raw", type=Path, help="transfer: ARGoS's raw rows, read and appended")
    parser.add_argument("--argos-jobs", type=int, default=1, help="transfer: ARGoS evaluations at once (1)")
    parser.add_argument("--tsv", type=Path, help="also write our statistics (transfer: the table) as a TSV")
    parser.add_argument("--out", type=Path, required=True, help="the markdown report to write")
    parser.add_argument("--force", action="store_true", help="replace a report or table (--tsv) that exists")
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
    """A reference tree in our syntax (the authors' read into ours, ``bt_controller.language.authors``); a
    network in the harness's form (``nn: w1 ... w56``, ``reference.network_of_subject``) as a network's
    text."""
    network = validation.network_of_subject(tree)
    if network is not None:
        return network_text(network)
    return from_authors(tree) if is_authors_syntax(tree) else tree


def our_estimates(
    trees: Sequence[str],
    seeds: Sequence[int],
    trials: int,
    config: Config,
    library: Library | None = None,
) -> dict[str, dict[str, validation.Estimate]]:
    """Per tree (a reference's text, or ours; or a swarm, ``reference.swarm_trees``), our estimates over
    ``seeds`` (one batch)."""
    requests = [_request(tree, seed, trials, config, library) for tree in trees for seed in seeds]
    results = BatchEvaluator(config, library=library).evaluate(requests)
    n = len(seeds)
    out = {}
    for index, tree in enumerate(trees):
        rows = []
        for result in results[index * n : (index + 1) * n]:
            if result.error is not None:
                raise UsageError(f"tree {tree!r}: {result.error}")
            assert result.fitness is not None and result.descriptors is not None
            rows.append(result.fitness + result.descriptors)
        out[tree] = validation.estimates(rows)
    return out


def _request(
    subject: str, seed: int, trials: int, config: Config, library: Library | None
) -> EvaluationRequest | SwarmRequest:
    """The evaluation of a reference's tree or swarm; UsageError naming it when it is not valid."""
    swarm = validation.swarm_trees(subject)
    try:
        if swarm is None:
            request = EvaluationRequest(ours(subject), seed, trials)
            check_request(request, library=library)
            return request
        return SwarmRequest(of_trees([ours(tree) for tree in swarm], config.n_robots, library), seed, trials)
    except ValueError as error:
        raise UsageError(f"tree {subject!r}: {error}") from None


MULTIFOOD_SETTING_KEYS = (
    "project",
    "arena",
    "formation",
    "trial_s",
    "iterations",
    "robots",
    "bias",
    "penalty",
    "build",
)
"""The keys of a multi-food reference's ``setting`` that ``multifood_task`` reads (the harness writes the
others only where they differ from the authors' defaults, which this project's arena tasks have)."""

MULTIFOOD_PROJECTS = (
    "straight_to_foraging",
    "heterogeneous_genetic_algorithm",
    "objectives_in_fitness_function",
)
"""The authors' projects that score deliveries: per kind, with one tree for all robots or one per robot, and
the 2024 slots (deliveries of kind 1 and the descriptors)."""

MULTIFOOD_BUILDS = ("multifood", "multifood-a73start")
"""The harness's builds of the 2026 code: unchanged, and with the 2024 start area ([-1, 1] m)."""


def multifood_task(setting: str) -> TaskSpec:
    """The task of a multi-food reference's ``setting`` (``project=...;arena=6;formation=random;trial_s=100;
    iterations=5;robots=9[;bias=1;penalty=0.5][;build=multifood-a73start]``): the foraging task on the
    authors' arena (``arena_task``), named as registered (``multifood-arena6``, ``multifood-arena9-kind2``);
    arena 1 with the 2024 start area is ``foraging-2026``. ValueError naming the key."""
    values: dict[str, str] = {}
    for item in setting.split(";"):
        key, equals, value = item.partition("=")
        if not equals or key not in MULTIFOOD_SETTING_KEYS:
            raise ValueError(
                f"setting {setting!r}: unknown item {item!r}; expected key=value with a key among "
                f"{', '.join(MULTIFOOD_SETTING_KEYS)}"
            )
        values[key] = value
    if values.get("project") not in MULTIFOOD_PROJECTS:
        raise ValueError(f"setting {setting!r}: project must be one of {', '.join(MULTIFOOD_PROJECTS)}")
    try:
        layout = int(values["arena"])
        bias = int(values["bias"]) if "bias" in values else None
        penalty = float(values.get("penalty", "1.0"))
        seconds = float(values.get("trial_s", "100"))
        trials = int(values.get("iterations", "5"))
        robots = int(values.get("robots", "9"))
    except (KeyError, ValueError) as error:
        raise ValueError(
            f"setting {setting!r}: arena, bias, penalty, trial_s, iterations and robots are "
            f"numbers, and arena is needed ({error})"
        ) from None
    build = values.get("build", "multifood")
    if build not in MULTIFOOD_BUILDS:
        raise ValueError(f"setting {setting!r}: build must be one of {', '.join(MULTIFOOD_BUILDS)}")
    name = f"multifood-arena{layout}" + ("" if bias is None else f"-kind{bias + 1}")
    base = replace(
        FORAGING,
        trials=Trials(ticks=round(seconds * 2), chain_trials=trials),
        robots=replace(FORAGING.robots, count=robots, formation=values.get("formation", "random")),
    )
    if build == "multifood-a73start":  # the 2024 start area: only their concentric arena has a task for it
        if layout != 1 or bias is not None:
            raise ValueError(f"setting {setting!r}: build {build} is checked on arena 1 only, without a bias")
        return replace(
            base,
            name=FORAGING_2026.name,
            description=FORAGING_2026.description,
            authors_code=FORAGING_2026.authors_code,
        )
    try:
        return arena_task(base, layout, bias=bias, other_food_weight=penalty, name=name)
    except ConfigError as error:
        raise ValueError(f"setting {setting!r}: {error}") from None


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


def _check_trials(args: argparse.Namespace) -> None:
    if not 1 <= args.trials <= 10_000:
        raise UsageError(f"--trials must be in [1, 10000], got {args.trials}")


def _seed_list(text: str, option: str) -> list[int]:
    seeds = transfer.parse_seeds(text)
    if not 2 <= len(seeds) <= 10_000:
        raise UsageError(f"{option} must name 2 to 10000 seeds (a standard error needs 2), got {len(seeds)}")
    return seeds


def _read_notes(path: Path | None) -> str | None:
    if path is None:
        return None
    try:
        return path.read_text(encoding="utf-8")
    except OSError as error:
        raise UsageError(f"--notes {path}: {error.strerror or error}") from None
    except UnicodeDecodeError as error:
        raise UsageError(f"--notes {path}: not UTF-8 text (byte {error.start}: {error.reason})") from None


def run(argv: Sequence[str]) -> tuple[argparse.Namespace, str, str]:
    """Parse ``argv`` and evaluate: (options, report markdown, our statistics or the transfer table as TSV).
    Raise UsageError."""
    args = _parser().parse_args(argv)
    shown = [argument for argument in argv if argument != "--force"]  # the report is the same without it
    try:  # before anything is evaluated: regenerated in place only with --force, never through a link
        check_output(args.out, args.force, "--out")
        table = table_path(args)
        if table is not None:
            check_output(table, args.force, "--tsv" if args.tsv is not None else "the table")
    except OSError as error:
        raise UsageError(str(error)) from None
    if args.transfer is not None:
        return args, *run_transfer(args, shown)
    for option in ("tree", "argos_eval", "argos_raw"):
        if getattr(args, option):
            raise UsageError(f"--{option.replace('_', '-')} belongs to --transfer")
    seeds = _seed_list(args.seeds or "20", "--seeds")
    _check_trials(args)
    config = model_config(args.profile)
    library = library_option(args.library, UsageError)
    foraging = replace(config, ticks=FORAGING.trials.ticks)
    notes = _read_notes(args.notes)
    transfer_rows = None if args.transfer_table is None else transfer.read_transfer_tsv(args.transfer_table)
    comparisons: list[validation.Comparison] = []
    tables: list[str] = []
    groups = (("", config, args.reference), ("foraging", foraging, args.foraging_reference))
    checked = [
        (g, world, _references(paths, args.trials, world.ticks, library)) for g, world, paths in groups
    ]
    checked += _multifood_references(args.multifood_reference, config.profile, args.trials, library)
    print(
        f"validate: {sum(len(r) for _, _, r in checked)} trees x {len(seeds)} seeds x {args.trials} trials",
        file=sys.stderr,
    )
    for group, world, references in checked:
        if not references:
            continue
        estimates = our_estimates(list(references), seeds, args.trials, world, library)
        for tree, stats in references.items():
            comparisons += validation.compare(tree, estimates[tree], stats, group)
        labelled = {f"[{group}] {t}" if group else t: e for t, e in estimates.items()}
        tables.append(stats_tsv(labelled, world.ticks))
    profile = getattr(config, "profile", None)
    command = "ws/run swarm_sim validate " + shlex.join(shown)
    tolerance = f"3 sqrt(2) SE_ARGoS + {validation.TOLERANCE_ABSOLUTE}"
    z_rule = f"|z| <= {validation.MAX_Z:g}, z = diff / sqrt(SE_ours² + SE_ARGoS²)"
    files = [*args.reference, *args.foraging_reference, *args.multifood_reference]
    header = [
        "# Validation against the authors' ARGoS simulation",
        "",
        f"Generated by `{command}`; do not edit by hand (explanations live in the `--notes` file).",
        "",
        f"- Model: profile `{profile or 'none (this model has no profiles)'}`. Ours: mean ± standard error "
        f"over {len(seeds)} evaluations per tree (seeds {_seeds_text(seeds)}, {args.trials} trials each).",
        f"- ARGoS: {', '.join(f'`{p}`' for p in files)} (mean ± "
        "standard error over its seeds; how they were measured: `docs/validation/README.md`). Movement and "
        "rotation mapped to [0, 1] as (x + T) / 2T for T ticks per trial (40; 200 in the `[foraging]` trees' "
        "100 s trials)"
        + (f"; primitives' names from `{args.library}`." if args.library else ".")
        + (
            " Multi-food rows are labelled with their task (`[multifood-arena6]`): the harness's setting as"
            " this project's task, under the same profile, deliveries per kind as `foraging1`-`foraging3` and"
            " their fitness as `foraging_biased`."
            if args.multifood_reference
            else ""
        ),
        f"- Tolerance (`docs/model.md`): agrees when |diff| <= {tolerance}; indistinguishable when it also "
        f"has {z_rule}.",
    ]
    if transfer_rows is not None:
        notes = "\n".join([*_transfer_section(transfer_rows, args.transfer_table), "", notes or ""])
    tsv = tables[0] + "".join(t.split("\n", 1)[1] for t in tables[1:])
    return args, validation.render(comparisons, header, notes), tsv


def table_path(args: argparse.Namespace) -> Path | None:
    """Where the TSV goes: ``--tsv``, else in transfer mode the report's name with ``.tsv``, else nowhere."""
    if args.tsv is not None:
        return Path(args.tsv)
    return Path(args.out).with_suffix(".tsv") if args.transfer is not None else None


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


def _multifood_references(
    paths: Sequence[Path], profile: str, trials: int, library: Library | None
) -> list[tuple[str, Config, dict[str, dict[str, validation.Estimate]]]]:
    """Per setting of the multi-food references (file order), its task's name, its world under ``profile`` and
    its trees' and swarms' statistics, each checked; UsageError naming the file and the problem."""
    out: list[tuple[str, Config, dict[str, dict[str, validation.Estimate]]]] = []
    for path in paths:
        try:
            settings = validation.read_multifood_reference(path, FORAGING.trials.ticks)
        except validation.ReferenceFileError as error:
            raise UsageError(str(error)) from None
        for setting, references in settings.items():
            try:
                task = multifood_task(setting)
            except ValueError as error:
                raise UsageError(f"{path}: {error}") from None
            world = task.config(profile)
            for subject in references:
                _request(subject, 1, trials, world, library)  # checked before anything is evaluated
            out.append((task.name, world, references))
    return out


def _seeds_text(seeds: Sequence[int]) -> str:
    if list(seeds) == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"{seeds[0]}-{seeds[-1]}"
    return ", ".join(map(str, seeds))


def _transfer_section(rows: Sequence[transfer.TransferRow], path: Path) -> list[str]:
    return [
        "## Transfer: trees evolved here, in ARGoS",
        "",
        f"From `{path}` (made by `validate --transfer`; its report beside it, with every quantity).",
        "",
        *transfer.render_summary(rows),
    ]


def run_transfer(args: argparse.Namespace, argv: Sequence[str]) -> tuple[str, str]:
    """The transfer check (module docstring): (report markdown, table TSV). Raise UsageError."""
    if args.transfer_table is not None or args.notes is not None or args.foraging_reference or args.library:
        raise UsageError(
            "--transfer-table, --notes, --foraging-reference and --library belong to --reference"
        )
    _check_trials(args)
    if not 0 <= args.per_run <= 512:
        raise UsageError(f"--per-run must be in [0, 512], got {args.per_run}")
    if not 2 <= args.evaluations <= 10_000:
        raise UsageError(
            f"--evaluations must be in [2, 10000] (a standard error needs 2), got {args.evaluations}"
        )
    if not 1 <= args.argos_jobs <= 64:
        raise UsageError(f"--argos-jobs must be in [1, 64], got {args.argos_jobs}")
    argos_seeds = _seed_list(args.seeds or "1-20", "--seeds")
    config = model_config(args.profile)
    picks = transfer.pick_trees(args.transfer, args.per_run)
    for tree in args.tree:
        if tree not in {p.tree for p in picks}:
            picks.append(transfer.Pick("hand", "", (), "hand", tree, None))
    for pick in picks:
        try:
            check_request(EvaluationRequest(pick.tree, 1, args.trials))
        except ValueError as error:
            raise UsageError(
                f"{pick.run} {pick.objective} bin {list(pick.bin)}: tree {pick.tree!r}: {error}"
            ) from None
    # Fresh scenarios: seeds 1.. that no run evolved on (a run under fixed scenarios used one seed).
    used = {s for s in map(transfer.scenario_seed, args.transfer) if s is not None}
    ours_seeds = [s for s in range(1, args.evaluations + len(used) + 1) if s not in used][: args.evaluations]
    trees = [p.tree for p in picks]
    raw_path = args.argos_raw or args.out.with_name(args.out.stem + "_argos_raw.tsv")
    try:
        refuse_links(raw_path)  # a cache, read and appended by the driver: never through a link
    except OSError as error:
        raise UsageError(f"--argos-raw {error}") from None
    argos, missing = transfer.argos_estimates(transfer.read_argos_raw(raw_path), trees, argos_seeds)
    if missing:
        harness = transfer.ArgosHarness.from_environment(args.argos_eval)
        todo = list(dict.fromkeys(tree for tree, _ in missing))
        print(
            f"validate: ARGoS: {len(missing)} evaluations of {len(todo)} trees into {raw_path}",
            file=sys.stderr,
        )
        with tempfile.TemporaryDirectory(prefix="transfer_") as work:
            harness.run(todo, argos_seeds, raw_path, args.argos_jobs, Path(work))
        argos, missing = transfer.argos_estimates(transfer.read_argos_raw(raw_path), trees, argos_seeds)
        if missing:
            tree, seed = missing[0]
            raise UsageError(
                f"{raw_path}: the ARGoS driver left {len(missing)} rows missing, e.g. {tree!r} seed {seed}"
            )
    print(
        f"validate: {len(trees)} trees x {len(ours_seeds)} seeds x {args.trials} trials here", file=sys.stderr
    )
    ours = our_estimates(trees, ours_seeds, args.trials, config)
    rows = [
        transfer.TransferRow(p, tuple(validation.compare(p.tree, ours[p.tree], argos[p.tree]))) for p in picks
    ]
    profile = getattr(config, "profile", None)
    header = [
        "# Transfer of evolved trees to the authors' ARGoS simulation",
        "",
        f"Generated by `ws/run swarm_sim validate {shlex.join(argv)}`; do not edit by hand.",
        "",
        f"- Trees: from each run's evolved grid its best and up to {args.per_run} more by farthest-point "
        "sampling of the bins (`swarm_sim.validation.transfer`); a tree picked before is passed over.",
        f"- Ours: profile `{profile}`, mean ± standard error over {len(ours_seeds)} evaluations per tree "
        f"(seeds {_seeds_text(ours_seeds)}, {args.trials} trials each; fresh: no run evolved on them).",
        f"- ARGoS: the harness's driver, seeds {_seeds_text(argos_seeds)} (raw rows: `{raw_path}`). "
        "Movement and rotation mapped to [0, 1] as (x + 40) / 80.",
        f"- Tolerance (`docs/model.md`): agrees when |diff| <= 3 sqrt(2) SE_ARGoS + "
        f"{validation.TOLERANCE_ABSOLUTE}; indistinguishable when it also has |z| <= {validation.MAX_Z:g}, "
        "z = diff / sqrt(SE_ours² + SE_ARGoS²).",
    ]
    return transfer.render_markdown(rows, header), transfer.transfer_tsv(rows)


def _write_text(path: Path, text: str) -> None:
    """UTF-8, a file name's bytes that are not UTF-8 (the command line quoted in the report) as ``\\xNN``."""
    shown = text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    path.write_text(shown, encoding="utf-8")


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point of ``validate``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args, report, tsv = run(argv)
        # written beside and renamed (swarm_ros.safe_paths): a symbolic link there is refused, not followed
        replace_file(args.out, lambda temporary: _write_text(temporary, report))
        tsv_path = table_path(args)
        if tsv_path is not None:
            replace_file(tsv_path, lambda temporary: _write_text(temporary, tsv))
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
