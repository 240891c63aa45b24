"""``experiment --study bt-vs-nn``: behaviour trees against the authors' 9-5-1 neural controller at equal
budget (issue 37).

    ws/run evolution_manager experiment --study bt-vs-nn --runs 10 --out experiments/bt-vs-nn

Arms: tree arms ``gp`` (GP_o) and ``qd`` (MAP-Elites over trees), network arms ``nn-cmaes``, ``nn-ga`` and
``nn-qd`` (``evolution.networks``); each on every objective of ``OBJECTIVES`` (the 2024 follow-up's six
primitives, on the primitives task, and foraging, on the foraging task; ``--objectives`` keeps some of them),
``--runs`` runs per arm and objective, each a run folder ``runs/<arm>/<objective>/run<r>``. GP_fnd is left
out: it evolves several objectives in one run at three times the budget, so it has no one-objective run of
equal budget to set beside a network's. Run ``r`` of arm ``a`` on objective ``k`` (its index in
``OBJECTIVES``, kept when ``--objectives`` shrinks the list) gets the seed ``derive_seed(--seed, RUN_STUDY,
NETWORKS_STAGE, a, k, r)``. Every run uses fixed scenarios (network runs know no other); under ``--design
shared`` (the default) every run of the study is evaluated on one scenario seed.

Equal budget: every run produces ``--evaluations`` controllers (25,000 by default). How each arm counts them:
GP and the GA count the offspring after their initial population of 25 (evaluated on top, as the paper's
GP); MAP-Elites over trees counts every tree after its initial batch of 100; CMA-ES and CMA-ME count every
sample. A tree arm simulates fewer than it counts: an offspring no operator changed keeps its parent's
fitness, and a tree seen before on the fixed scenario is answered from the run's cache; a network arm
simulates every network it counts (the GA's three elites are not evaluated again). A run also re-scores its
best controller on five held-out scenarios at its end.

The report (``report.md``, regenerated from ``runs.csv`` and the run folders, in the plan's order, so a
continued study writes the same bytes): per objective and arm the mean best and held-out best fitness with
95 % bootstrap intervals of the mean, the paper's tests (``significance.compare``: Welch's t-test or
Mann-Whitney U after Shapiro-Wilk) with Holm's correction over two families, figures, and what a person can
read of each objective's best network: its action for every one of the 2^9 input patterns
(``networks/<objective>.csv``), and in the report those patterns grouped by action as a few conditions.
"""

from __future__ import annotations

import argparse
import csv
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from bt_controller.draws import RUN_STUDY, derive_seed
from bt_controller.interpreters import INPUT_NAMES, INPUTS, N_INPUTS, act, load_network
from bt_controller.language import ACTIONS, N_CONDITIONS
from evolution_manager.errors import EvolutionError, UsageError
from evolution_manager.evolution.networks import ALGORITHMS as NETWORK_ARMS
from evolution_manager.evolution.networks import NetworkConfig
from evolution_manager.evolution.run_config import DEFAULT_PROFILE, RunConfig
from evolution_manager.files import read_json, write_atomic
from evolution_manager.studies import networks_transfer
from evolution_manager.studies.foraging_transfer import DEFAULT_SEEDS
from evolution_manager.studies.intervals import interval
from evolution_manager.studies.planning import PLAN_FILE, document_head, shared_scenario_seed
from evolution_manager.studies.significance import Comparison, compare, holm, markdown_table
from swarm_ros.safe_paths import make_folder
from swarm_sim.model import FAMILIES

STUDY = "bt-vs-nn"
NETWORKS_STAGE = 6
"""The stage index of this study's seeds (the foraging study uses 0 to 3, replication 4, ablation 5)."""
TREE_ARMS: tuple[str, ...] = ("gp", "qd")
ARMS: tuple[str, ...] = (*TREE_ARMS, *NETWORK_ARMS)
REPERTOIRE_ARMS: tuple[str, ...] = ("qd", "nn-qd")
"""The arms whose runs report coverage and QD score."""
OBJECTIVES: tuple[str, ...] = (*FAMILIES, "foraging")
"""The six primitives of the 2024 follow-up, then foraging."""
CSV_HEADER = ["arm", "objective", "seed", "best_fitness", "heldout_best_fitness", "coverage", "qd_score"]
SHOWN_CONDITIONS = 12
"""The most conditions the report lists for one action of a network (the CSV has every pattern)."""


def chosen_objectives(text: str | None) -> list[str]:
    """The objectives of ``--objectives`` (comma-separated, in ``OBJECTIVES`` order), all when None."""
    if text is None:
        return list(OBJECTIVES)
    given = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in given if name not in OBJECTIVES]
    if unknown or not given:
        raise UsageError(f"--objectives takes some of {','.join(OBJECTIVES)}, got {text!r}")
    return [name for name in OBJECTIVES if name in given]


def _config(
    arm: str, objective: str, args: argparse.Namespace, seed: int, scenario_seed: int | None
) -> RunConfig | NetworkConfig:
    task = "foraging" if objective == "foraging" else "primitives"
    if arm in NETWORK_ARMS:
        return NetworkConfig(
            arm,
            objective,
            args.evaluations,
            seed,
            args.trials,
            args.profile or DEFAULT_PROFILE,
            task,
            -1 if scenario_seed is None else scenario_seed,
        )
    return RunConfig.make(
        arm, objective, args.evaluations, seed, args.trials, "fixed", scenario_seed, args.profile, task=task
    )


def plan_study(
    args: argparse.Namespace, scenarios: str, design: str | None
) -> tuple[dict, list, dict[str, int]]:
    """The study's plan document, its one stage and the budget of every run, from the command line."""
    if scenarios != "fixed":
        raise UsageError("--study bt-vs-nn runs under fixed scenarios only (network runs know no other)")
    objectives = chosen_objectives(args.objectives)
    scenario_seed = args.scenario_seed
    if design == "shared" and scenario_seed is None:
        scenario_seed = shared_scenario_seed(args.seed)
    planned = []
    entries = []
    for a, arm in enumerate(ARMS):
        for objective in objectives:
            k = OBJECTIVES.index(objective)
            for r in range(args.runs):
                seed = derive_seed(args.seed, RUN_STUDY, NETWORKS_STAGE, a, k, r)
                made = _config(arm, objective, args, seed, scenario_seed)
                folder = f"runs/{arm}/{objective}/run{r:02d}"
                planned.append((made, folder))
                entries.append({"arm": arm, "objective": objective, "dir": folder, "config": made.to_json()})
    document = {
        "study": STUDY,
        **document_head(args, args.profile or DEFAULT_PROFILE, scenarios, design, scenario_seed),
        "objectives": objectives,
        "plan": entries,
    }
    return document, [lambda: planned], {folder: made.evaluations for made, folder in planned}


# Reading the runs -----------------------------------------------------------------------------------------
def _number(value: object) -> str:
    return "" if value is None else repr(float(value))  # type: ignore[arg-type]  # a JSON number


def _row(entry: dict, summary: dict) -> dict[str, str]:
    """The ``runs.csv`` row of a finished run from its summary (a tree run's or a network run's)."""
    arm, objective = entry["arm"], entry["objective"]
    if arm in NETWORK_ARMS:
        best = summary["best"]
        scores = {
            "best_fitness": None if best is None else best["fitness"],
            "heldout_best_fitness": summary["heldout_best_fitness"],
            "coverage": summary["coverage"],
            "qd_score": summary["qd_score"],
        }
    else:
        scores = summary["objectives"][objective]
    repertoire = arm in REPERTOIRE_ARMS
    return {
        "arm": arm,
        "objective": objective,
        "seed": str(entry["config"]["seed"]),
        "best_fitness": _number(scores["best_fitness"]),
        "heldout_best_fitness": _number(scores["heldout_best_fitness"]),
        "coverage": _number(scores["coverage"]) if repertoire else "",
        "qd_score": _number(scores["qd_score"]) if repertoire else "",
    }


def finished_runs(root: Path) -> tuple[dict, list[tuple[dict, dict[str, str]]]]:
    """The study's plan document and its finished runs, in the plan's order: each plan entry with its row."""
    document = read_json(Path(root) / PLAN_FILE)
    if not isinstance(document, dict) or document.get("study") != STUDY:
        raise EvolutionError(f"{root} is not a {STUDY} study ({PLAN_FILE})")
    found = []
    for entry in document["plan"]:
        path = Path(root) / entry["dir"] / "summary.json"
        summary = read_json(path) if path.exists() else None
        if isinstance(summary, dict) and summary.get("finished") and summary.get("heldout") is not None:
            found.append((entry, _row(entry, summary)))
    return document, found


def _values(table: Sequence[dict[str, str]], arm: str, objective: str, key: str) -> list[float]:
    return [float(r[key]) for r in table if r["arm"] == arm and r["objective"] == objective and r[key] != ""]


# What a network does ---------------------------------------------------------------------------------------
def action_table(weights: Sequence[float]) -> list[int]:
    """The action (``ACTIONS`` index) the network picks for each of the 2^9 input patterns: pattern ``p``
    sets input ``i`` (``INPUT_NAMES`` order) to bit ``8 - i`` of ``p``, so that ``format(p, "09b")`` reads
    the inputs in order."""
    array = np.asarray(weights, dtype=np.float64)
    actions = []
    for p in range(2**N_INPUTS):
        board = np.zeros(N_CONDITIONS, dtype=np.bool_)
        for i in range(N_INPUTS):
            board[INPUTS[i]] = bool((p >> (N_INPUTS - 1 - i)) & 1)
        actions.append(int(act(array, board)))
    return actions


def cover(patterns: set[int], n: int = N_INPUTS) -> list[str]:
    """A short list of cubes (``"1-0------"``: ``-`` any value) whose patterns are exactly ``patterns``:
    the prime implicants of Quine and McCluskey, then a greedy cover (the largest first, ties in order)."""
    current = {(p, 0) for p in patterns}  # (values, mask of any-value bits)
    primes: set[tuple[int, int]] = set()
    while current:
        merged, used = set(), set()
        for value, mask in current:
            for bit in range(n):
                b = 1 << bit
                if not (mask | value) & b and (value | b, mask) in current:
                    merged.add((value, mask | b))
                    used.update({(value, mask), (value | b, mask)})
        primes |= current - used
        current = merged
    members = {}
    for value, mask in sorted(primes):
        free = [1 << bit for bit in range(n) if mask & (1 << bit)]
        members[(value, mask)] = {value | sum(b for k, b in enumerate(free) if (s >> k) & 1)
                                  for s in range(2 ** len(free))}  # fmt: skip
    left, chosen = set(patterns), []
    while left:
        pick = max(sorted(members), key=lambda cube: len(members[cube] & left))
        chosen.append(pick)
        left -= members[pick]
    return ["".join("-" if mask >> (n - 1 - i) & 1 else str(value >> (n - 1 - i) & 1) for i in range(n))
            for value, mask in chosen]  # fmt: skip


def cube_text(cube: str) -> str:
    """A cube as conditions on the named inputs (``in_nest and not got_food``), ``any input`` when free."""
    words = [
        name if c == "1" else f"not {name}" for name, c in zip(INPUT_NAMES, cube, strict=True) if c != "-"
    ]
    return " and ".join(words) or "any input"


def write_action_csv(path: Path, actions: Sequence[int]) -> None:
    """``path``: one row per input pattern, the nine inputs (0 or 1) and the action picked."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow([*INPUT_NAMES, "action"])
    for p, a in enumerate(actions):
        writer.writerow([*format(p, f"0{N_INPUTS}b"), ACTIONS[a]])
    make_folder(path.parent)
    write_atomic(path, buffer.getvalue())


def _best_run(
    found: Sequence[tuple[dict, dict[str, str]]], objective: str, arms: Sequence[str]
) -> tuple[dict[str, str], str] | None:
    """The run of one of ``arms`` on ``objective`` with the highest held-out best fitness (in-run best among
    equals or without one): (its row, its folder)."""
    mine = [
        (row, entry["dir"])
        for entry, row in found
        if row["arm"] in arms and row["objective"] == objective and row["best_fitness"] != ""
    ]
    if not mine:
        return None
    return max(
        mine,
        key=lambda item: (float(item[0]["heldout_best_fitness"] or "-inf"), float(item[0]["best_fitness"])),
    )


def _scores(row: dict[str, str]) -> str:
    held = row["heldout_best_fitness"]
    return f"best {float(row['best_fitness']):.4g}, held-out " + (f"{float(held):.4g}" if held else "n/a")


def _best_tree(root: Path, found: Sequence[tuple[dict, dict[str, str]]], objective: str) -> str:
    """The best tree of ``objective`` (the tree run with the highest held-out best fitness), simplified, to
    set beside the network."""
    best = _best_run(found, objective, TREE_ARMS)
    if best is None:
        return ""
    row, folder = best
    summary = read_json(Path(root) / folder / "summary.json")
    assert isinstance(summary, dict)  # a finished tree run's summary
    tree = summary["objectives"][objective]["best_tree_simplified"]
    head = f"Beside it the best tree, {row['arm']} seed {row['seed']} ({_scores(row)}), simplified:"
    return f"{head}\n\n    {tree}\n\n"


def best_controllers(
    root: Path, found: Sequence[tuple[dict, dict[str, str]]], objectives: Sequence[str]
) -> list[networks_transfer.Best]:
    """Per objective, its best tree and its best network (``_best_run``), as the ARGoS harness reads them."""
    bests = []
    for objective in objectives:
        for kind, arms in (("tree", TREE_ARMS), ("network", NETWORK_ARMS)):
            best = _best_run(found, objective, arms)
            if best is None:
                continue
            row, folder = best
            if kind == "tree":
                summary = read_json(Path(root) / folder / "summary.json")
                assert isinstance(summary, dict)  # a finished tree run's summary
                subject = str(summary["objectives"][objective]["best_tree"])
            else:
                network = load_network(Path(root) / folder / "best" / f"{objective}.json")
                subject = networks_transfer.network_subject(network.weights)
            held = row["heldout_best_fitness"]
            bests.append(
                networks_transfer.Best(
                    objective, kind, row["arm"], row["seed"], folder, subject, float(held) if held else None
                )
            )
    return bests


def _network_section(
    root: Path, found: Sequence[tuple[dict, dict[str, str]]], objectives: Sequence[str]
) -> str:
    parts = []
    for objective in objectives:
        best = _best_run(found, objective, NETWORK_ARMS)
        if best is None:
            continue
        row, folder = best
        network = load_network(Path(root) / folder / "best" / f"{objective}.json")
        actions = action_table(network.weights)
        write_action_csv(Path(root) / "networks" / f"{objective}.csv", actions)
        parts.append(
            f"### {objective}: {row['arm']}, seed {row['seed']} ({_scores(row)})\n\n"
            f"{_best_tree(root, found, objective)}"
            f"Every input pattern's action: [networks/{objective}.csv](networks/{objective}.csv); the "
            f"network: `{folder}/best/{objective}.json`.\n\n| action | patterns | when |\n|---|---|---|"
        )
        for a, name in enumerate(ACTIONS):
            patterns = {p for p, picked in enumerate(actions) if picked == a}
            if not patterns:
                continue
            cubes = cover(patterns)
            shown = "; ".join(cube_text(c) for c in cubes[:SHOWN_CONDITIONS])
            more = f"; and {len(cubes) - SHOWN_CONDITIONS} more" if len(cubes) > SHOWN_CONDITIONS else ""
            parts.append(f"| {name} | {len(patterns)} | {shown}{more} |")
        parts.append("")
    return "\n".join(parts) + "\n"


# The report ------------------------------------------------------------------------------------------------
def _ci(values: Sequence[float], rng: np.random.Generator) -> str:
    if not values:
        return "n/a"
    mean = sum(values) / len(values)
    bounds = interval(values, "mean", rng)
    return f"{mean:.4g}" + ("" if bounds is None else f" [{bounds[0]:.4g}, {bounds[1]:.4g}]")


def scores_table(table: Sequence[dict[str, str]], objectives: Sequence[str]) -> str:
    """Per objective and arm: runs, mean best and held-out best fitness (and coverage and QD score for the
    repertoire arms) with 95 % bootstrap intervals of the mean (a fixed generator: the same table each
    time)."""
    rng = np.random.default_rng(0)
    lines = [
        "| objective | arm | runs | best fitness | held-out best fitness | coverage | QD score |",
        "|---|---|---|---|---|---|---|",
    ]
    for objective in objectives:
        for arm in ARMS:
            best = _values(table, arm, objective, "best_fitness")
            if not best:
                continue
            cells = [_ci(_values(table, arm, objective, key), rng) for key in CSV_HEADER[4:]]
            if arm not in REPERTOIRE_ARMS:
                cells[1:] = ["", ""]
            lines.append(f"| {objective} | {arm} | {len(best)} | {_ci(best, rng)} | {' | '.join(cells)} |")
    return "\n".join(lines) + "\n"


def comparisons(table: Sequence[dict[str, str]], objectives: Sequence[str]) -> tuple[list, list]:
    """The two families of tests, each Holm-corrected on its own: trees against networks on the held-out
    best fitness (``gp`` against ``nn-cmaes`` and ``nn-ga``, per objective), and repertoires of trees
    against repertoires of networks (``qd`` against ``nn-qd`` on coverage and QD score, per objective). A
    comparison with an arm that has no finished run yet is left out."""
    best: list[Comparison] = []
    repertoires: list[Comparison] = []
    for objective in objectives:
        for network in ("nn-cmaes", "nn-ga"):
            a = _values(table, "gp", objective, "heldout_best_fitness")
            b = _values(table, network, objective, "heldout_best_fitness")
            if a and b:
                best.append(compare("held-out best fitness", objective, "gp", a, network, b))
        for key, metric in (("coverage", "coverage"), ("qd_score", "QD score")):
            a, b = _values(table, "qd", objective, key), _values(table, "nn-qd", objective, key)
            if a and b:
                repertoires.append(compare(metric, objective, "qd", a, "nn-qd", b))
    return holm(best) if best else [], holm(repertoires) if repertoires else []


def _figures(root: Path, table: Sequence[dict[str, str]], objectives: Sequence[str]) -> list[str]:
    # matplotlib (about 1.5 s to import) loads only when figures are drawn
    from evolution_manager.viewing import figures

    drawn = []
    for key, metric, arms in (
        ("best_fitness", "best fitness", ARMS),
        ("heldout_best_fitness", "held-out best fitness", ARMS),
        ("coverage", "coverage", REPERTOIRE_ARMS),
        ("qd_score", "QD score", REPERTOIRE_ARMS),
    ):
        samples = {
            o: {arm: _values(table, arm, o, key) for arm in arms if _values(table, arm, o, key)}
            for o in objectives
        }
        samples = {o: by_arm for o, by_arm in samples.items() if by_arm}
        if samples:
            path = figures.boxes(samples, metric, Path(root) / "figures" / f"{key}.png")
            drawn.append(f"![{metric}](figures/{path.name})")
    return drawn


def build_report(
    root: Path,
    argos_eval: str | None = None,
    argos_seeds: Sequence[int] = DEFAULT_SEEDS,
    argos_jobs: int = 1,
) -> Path:
    """Write ``runs.csv``, ``report.md``, ``figures/`` and ``networks/`` of the study in ``root`` from its
    finished runs; return the report's path. ``argos_eval``: the ARGoS harness's driver, to score first each
    objective's best tree and best network where their rows are missing; with rows there the report has a
    section on them (``networks_transfer``)."""
    root = Path(root)
    document, found = finished_runs(root)
    if not found:
        raise EvolutionError(f"{root} has no finished runs yet")
    bests = best_controllers(root, found, document["objectives"])
    if argos_eval is not None:
        networks_transfer.measure(root, bests, argos_eval, argos_seeds, argos_jobs)
    if networks_transfer.has_rows(root):
        argos = "\n" + networks_transfer.section(root, bests, argos_seeds, document["profile"])
    else:
        argos = ""
    table = [row for _, row in found]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, CSV_HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(table)
    write_atomic(root / "runs.csv", buffer.getvalue())
    objectives = document["objectives"]
    best, repertoires = comparisons(table, objectives)
    none = "No pair of arms with finished runs yet.\n"
    text = (
        f"# Behaviour trees against neural networks: {root.name}\n\n"
        f"{len(table)} of {len(document['plan'])} planned runs finished ({document['runs']} per arm and "
        f"objective, {document['evaluations']:,} evaluations each, {document['trials']} trials per "
        f"evaluation, profile {document['profile']}, design {document['design']}); one row per run in "
        "[runs.csv](runs.csv).\n\n"
        "Equal budget is the same number of controllers produced per run. GP and the GA count their "
        "offspring after the initial population of 25, MAP-Elites over trees every tree after its initial"
        " batch of 100, CMA-ES and CMA-ME every sample. Tree arms simulate fewer than they count (an "
        "offspring no operator changed keeps its parent's fitness, a tree seen before on the fixed "
        "scenario is answered from the run's cache); network arms simulate every network they count. "
        "Held-out best fitness: the run's best controller re-scored on five scenarios it never saw "
        "(mean). A network ticks no condition, so its conditionality descriptor is 0: an nn-qd repertoire"
        " fills at most the 64 bins of one slice of the 512, coverage 0.125 at most."
        "\n\n"
        "## Scores\n\nMeans with 95 % bootstrap intervals of the mean (10,000 resamples).\n\n"
        f"{scores_table(table, objectives)}\n"
        "## Does readability cost performance?\n\n"
        "The paper's tests (Shapiro-Wilk on each sample, then Welch's t-test or Mann-Whitney U), Holm's "
        "correction over the family of every row of this table: GP over trees against CMA-ES and the GA over "
        "networks, on the held-out best fitness, per objective. Significant rows in bold.\n\n"
        f"{markdown_table(best) if best else none}\n"
        "## Repertoires of trees against repertoires of networks\n\n"
        "The same tests, Holm's correction over the family of this table: MAP-Elites over trees (qd) against "
        "MAP-Elites over networks (nn-qd, CMA-ME), on coverage and QD score, per objective.\n\n"
        f"{markdown_table(repertoires) if repertoires else none}\n"
        "## Figures\n\nTree arms (gp, qd) beside network arms (nn-cmaes, nn-ga, nn-qd).\n\n"
        + "\n\n".join(_figures(root, table, objectives))
        + "\n\n## What the best networks and trees do\n\n"
        "For each objective the network run with the highest held-out best fitness, beside the best tree "
        "run's tree simplified: the network's action for each of the 2^9 patterns of its inputs (in_nest, "
        "on_food, got_food (carrying), nest_left, nest_right, food_left, food_right, robot_left, "
        "robot_right), the patterns of each action summed up as "
        "conditions (a short cover of the patterns: a pattern that meets one condition picks the action)."
        "\n\n"
        f"{_network_section(root, found, objectives)}"
        f"{argos}"
    )
    write_atomic(root / "report.md", text)
    return root / "report.md"
