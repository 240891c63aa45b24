"""``adapt-benchmark``: Intelligent Trial and Error, per swarm and per robot, beside its baselines, on
conditions where the repertoire's best tree no longer does.

    ws/run evolution_manager adapt-benchmark --repertoires RUN_DIR [RUN_DIR ...] \\
        [--condition-set faults=0.5:wheel-dead,wheel-reversed --condition-set dead-robots=6 ...] \\
        [--seeds 10] [--budget 30] [--ceiling N] [--keep-below 0.7] [--heldout 20] --out DIR

The repertoires share one setting (``search.repertoire_setting``: profile, task, library), so the benchmark
works for a primitive's repertoire (``repertoire_food.json`` of a QD run) and for a foraging repertoire (a
``foragers-qd`` run of ``experiments/foraging``, its trees built of the library's primitives) alike; the
objective is the repertoires' own unless ``--objective`` names another.

1. **Which conditions.** Each candidate condition set (``--condition-set``, repeatable, ``NAME=VALUE``
   conditions joined by commas; without one, ``CANDIDATES``) is kept only where the repertoire's best tree,
   unchanged, falls below ``--keep-below`` (70 %) of its fault-free score on ``--filter-scenarios`` (20)
   fresh scenarios (median over the repertoires: ``kept``). ``conditions.csv`` holds every candidate's
   scores, kept or not, by fault family (``fault_family``).
2. **The methods**, on every kept condition and seed ``s`` in 1..``--seeds`` (10; scenario ``s``: every
   evaluation of a seed on the same fixed scenario, so all methods are scored alike):

   - ``unchanged``: the repertoire's best tree, as it is;
   - ``ite``: Intelligent Trial and Error over the repertoire, every robot the same tree (``adapt``'s
     search, the whole budget; where its stopping rule would have stopped is recorded too);
   - ``ite-per-robot``: the same search, but only the robots the condition strikes change tree, the others
     keep the best one (``search.CompositionEvaluation``, whose module says why this search space);
   - ``random``: distinct bins of the repertoire drawn at random;
   - ``qd-scratch`` and ``gp-scratch``: MAP-Elites and GP_o from scratch in the changed world, the same
     budget (each with a seed of its own derived from ``s``);
   - the ceiling: the best fitness MAP-Elites and GP_o find from scratch in the changed world with
     ``--ceiling`` evaluations (default: the repertoire run's own budget), per seed (of the first
     ``--ceiling-seeds``: it is only a reference, and the costliest part by far).

   The repertoire methods run once per repertoire and seed; the scratch methods and the ceiling once per
   seed (their pre-fault reference: the repertoires' mean).
3. **The measures.** The pre-fault score: the best tree in the world without the condition, on scenario
   ``s``. ``trials_to_90``: the first trial whose best so far reaches 90 % of it. Every method's pick (its
   best so far after 10 trials and at the budget) is re-scored on ``--heldout`` (20) held-out scenarios,
   seeded and disjoint from every adaptation and filter scenario (``scenario_seeds``), beside the best tree's
   fault-free score on the same scenarios: the winner's curse of a maximum of noisy scores shows there.
   Every fraction (the filter's included) counts from ``--floor`` (default 0), the score of a swarm that
   does nothing useful (``relative``). A primitive's fitness such as food is 0.5 when its estimate never
   changes, so 70 % of a fault-free 0.78 is 0.55, barely above doing nothing: ``--floor 0.5`` measures such
   an objective from there.

Writes ``DIR/runs.csv`` (one row per method, task, condition, seed and repertoire: ``RUN_HEADER``),
``DIR/trials.csv`` (every trial of every run: its tree, fitness and best so far), ``DIR/conditions.csv``,
``DIR/ceilings.csv``, ``DIR/summary.json``, ``DIR/curves.png`` and ``DIR/report.md`` (per fault family: the
conditions kept, the median trials to 90 % of the pre-fault score, the fraction recovered within 10 and 30
trials, the held-out re-scores, per robot against per swarm, and SMBO's published figure beside ours). The
filter's scores in ``conditions.csv`` and the ceilings in ``ceilings.csv`` are reused, and the ceiling whose
search was running continues from ``DIR/ceiling-checkpoint.json`` (saved every two minutes, removed when
that ceiling is written), so an interrupted benchmark continues where its costly parts ended, with the same
results.

``--cluster dask://HOST:PORT`` or ``--cluster slurm`` (``--cluster-config FILE``) evaluates on a Dask
cluster's workers, each changed world sent whole to them (``cluster.evaluator.DaskEvaluator``), instead of in
this process; the files are the same either way (the cluster is not recorded in them). The methods still run
one after another, so this pays for the ceilings' runs (batches of 25 to 100 evaluations), not for the
adaptation trials (one evaluation each); the per-robot swarms are always evaluated in this process.
"""

from __future__ import annotations

import argparse
import csv
import functools
import io
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bt_controller.draws import MAX_SEED, derive_seed
from evolution_manager.adaptation.search import (
    AdaptationError,
    CompositionEvaluation,
    ConditionEvaluation,
    IntelligentTrialAndError,
    ITEParameters,
    RandomPicks,
    RepertoireSetting,
    SearchCheckpoint,
    Tried,
    best_so_far,
    composition,
    load_candidates,
    reevolve,
    repertoire_setting,
    run_picker,
    saved_search,
    struck_robots,
)
from evolution_manager.arguments import EXIT_IO, EXIT_USAGE, Parser, finite, positive_int
from evolution_manager.cluster.client import open_client
from evolution_manager.cluster.settings import ClusterError, add_cluster_options, settings_from_args
from evolution_manager.errors import DispatchError, UsageError, WriteError
from evolution_manager.evolution.run_config import OBJECTIVES
from evolution_manager.files import write_atomic, write_json
from swarm_ros.safe_paths import make_folder, refuse_links
from swarm_sim.errors import ConditionError
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, Evaluator, SwarmRequest
from swarm_sim.model import FAULT_KINDS, Config, apply_conditions

if TYPE_CHECKING:  # Dask loads only for a cluster
    from distributed import Client

METHODS: tuple[str, ...] = ("unchanged", "ite", "ite-per-robot", "random", "qd-scratch", "gp-scratch")
LABELS = {
    "unchanged": "repertoire's best, unchanged",
    "ite": "Intelligent Trial and Error (every robot)",
    "ite-per-robot": "Intelligent Trial and Error per robot (struck robots)",
    "random": "random picks from the repertoire",
    "qd-scratch": "MAP-Elites from scratch",
    "gp-scratch": "GP_o from scratch",
}
TARGET = 0.9
"""The goal: reach this fraction of the pre-fault score."""
KEEP_BELOW = 0.7
"""A candidate condition is kept where the unchanged best tree keeps less than this of its fault-free
score."""
EARLY = 10
"""The early pick: the best so far after this many trials (also re-scored on the held-out scenarios)."""
RECOVERED_AT: tuple[int, ...] = (10, 30)
"""The report's fractions of runs recovered (to 90 % of the pre-fault score) within these many trials."""
SMBO_FIGURE = (
    'SMBO (Bossens and Tarapore, "Rapidly adapting robot swarms with Swarm Map-based Bayesian '
    "Optimisation\"), on foraging with faults in individual robots' sensors and actuators: up to 80 % "
    "recovery over the moment of fault injection within at most 30 evaluations"
)
_EVERY_KIND = ",".join(FAULT_KINDS)
CANDIDATES: tuple[str, ...] = (
    "faults=0.3:ground-stuck,ground-inverted",
    "faults=0.6:ground-stuck,ground-inverted",
    "faults=0.9:ground-stuck,ground-inverted",
    "faults=0.3:rab-deaf,rab-noisy,rab-mirrored",
    "faults=0.6:rab-deaf,rab-noisy,rab-mirrored",
    "faults=0.3:wheel-dead,wheel-weak,wheel-reversed",
    "faults=0.6:wheel-dead,wheel-weak,wheel-reversed",
    "faults=0.9:wheel-dead,wheel-weak,wheel-reversed",
    "faults=0.2:disruptive",
    "faults=0.4:disruptive",
    f"faults=0.3:{_EVERY_KIND}",
    f"faults=0.6:{_EVERY_KIND}",
    "dead-robots=5",
    "dead-robots=7",
    "dead-robots=8",
    "message-loss=0.9",
)
"""The candidate conditions when no ``--condition-set`` is given: each fault family at two or three rates,
every kind together, more dead robots than the first benchmark's 3 and a near-deaf radio. A ground fault
changes what a robot reads, never where food is picked up or delivered (``swarm_sim.model.faults``)."""
FAMILIES: dict[str, str] = {
    "ground-stuck": "ground sensor",
    "ground-inverted": "ground sensor",
    "rab-deaf": "receiver",
    "rab-noisy": "receiver",
    "rab-mirrored": "receiver",
    "wheel-dead": "wheel",
    "wheel-weak": "wheel",
    "wheel-reversed": "wheel",
    "disruptive": "disruptive robot",
    "dead-robots": "dead robots",
    "weak-wheel": "wheel",
    "message-loss": "radio",
    "robots": "swarm size",
    "gap": "resources",
    "food-disc": "resources",
}
"""The fault family of each fault kind and condition name."""
RUN_HEADER = [
    "method",
    "task",
    "condition",
    "seed",
    "repertoire",
    "trials_to_90",
    "heldout_final",
    "heldout_at_10",
    "heldout_pre_fault",
    "pre_fault",
    "best_at_budget",
    "stopping_rule_trials",
]
TRIAL_HEADER = [
    "task",
    "condition",
    "method",
    "repertoire",
    "seed",
    "trial",
    "tree",
    "fitness",
    "best_so_far",
]
CEILING_HEADER = [
    "condition",
    "seed",
    "algorithm",
    "evaluations",
    "simulated",
    "best_fitness",
    "tree",
    "profile",
]
FILTER_HEADER = [
    "condition",
    "family",
    "repertoire",
    "scenarios",
    "fault_free",
    "changed",
    "ratio",
    "profile",
]
_PURPOSE_RANDOM = 71
_PURPOSE_SCRATCH = 72
_PURPOSE_FILTER = 73
_PURPOSE_HELDOUT = 74


def _number_option(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """The ``adapt-benchmark`` command line."""
    parser = Parser(prog="adapt-benchmark", description=__doc__.split("\n")[0])
    parser.add_argument("--repertoires", type=Path, nargs="+", required=True, help="run directories")
    parser.add_argument(
        "--objective", choices=OBJECTIVES, default=None, help="objective (default: the repertoires' own)"
    )
    parser.add_argument(
        "--condition-set",
        action="append",
        default=None,
        metavar="NAME=VALUE[,NAME=VALUE]",
        help="one candidate changed world (repeatable; default: the built-in candidates)",
    )
    parser.add_argument("--seeds", type=positive_int, default=10, help="seeds 1..N (default 10)")
    parser.add_argument("--budget", type=positive_int, default=30, help="adaptation trials (default 30)")
    parser.add_argument(
        "--ceiling",
        type=positive_int,
        default=None,
        help="ceiling evaluations (default: the repertoire run's own evaluations)",
    )
    parser.add_argument(
        "--ceiling-seeds",
        type=positive_int,
        default=None,
        help="seeds 1..K that get a ceiling (default: every seed; the ceiling is only a reference)",
    )
    parser.add_argument("--trials", type=positive_int, default=10, help="simulated trials per evaluation")
    parser.add_argument(
        "--keep-below",
        type=finite(0.0, strictly=True, what="number"),
        default=KEEP_BELOW,
        help="keep a condition where the unchanged best keeps less than this of its score (0.7)",
    )
    parser.add_argument(
        "--floor",
        type=_number_option,
        default=0.0,
        help="the score of a swarm that does nothing useful; every fraction counts from it (default 0)",
    )
    parser.add_argument(
        "--filter-scenarios", type=positive_int, default=20, help="fresh scenarios of the filter (20)"
    )
    parser.add_argument(
        "--heldout", type=positive_int, default=20, help="held-out scenarios re-scoring each pick (20)"
    )
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    parser.add_argument("--no-progress", action="store_true", help="no progress lines on stderr")
    add_cluster_options(parser)
    return parser


def _csv_text(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


def _read_ceilings(path: Path, profile: str) -> dict[tuple[str, int, str], list[str]]:
    """The ceilings already found (under the model's ``profile``: a file of another refused)."""
    if not path.is_file():
        return {}
    with path.open(newline="") as handle:
        rows = list(csv.reader(handle))
    if not rows or rows[0] != CEILING_HEADER:
        raise UsageError(
            f"{path} is not a ceilings file of this benchmark: remove it or choose another --out"
        )
    other = {r[-1] for r in rows[1:]} - {profile}
    if other:
        raise UsageError(
            f"{path} holds ceilings of the model profile {sorted(other)[0]}, the repertoires' is {profile}: "
            "remove it or choose another --out"
        )
    return {(r[0], int(r[1]), r[2]): r for r in rows[1:]}


def trials_to_target(curve: Sequence[float], bar: float) -> float:
    """The first trial (1-based) whose best so far reaches ``bar``; infinity when none does."""
    for k, value in enumerate(curve):
        if value >= bar:
            return float(k + 1)
    return math.inf


def split_condition_set(text: str) -> list[str]:
    """The ``NAME=VALUE`` conditions of one condition set: its pieces at commas, a piece without ``=`` (a
    fault kind of ``faults=RATE:KIND,KIND``) joined back to the condition before it."""
    out: list[str] = []
    for piece in (p.strip() for p in text.split(",")):
        if not piece:
            continue
        if "=" not in piece and out:
            out[-1] += f",{piece}"
        else:
            out.append(piece)
    return out


def fault_family(config: Config, record: dict[str, object]) -> str:
    """The fault family of a condition set (``FAMILIES``): of its fault kinds (those named, those of a fault
    file, every kind under a bare rate) and other conditions; ``mixed`` when they are of several."""
    families = set()
    for name in record:
        if name != "faults":
            families.add(FAMILIES[name])
    if "faults" in record:
        kinds = [kind for _, kind in config.fault_robots] or list(config.fault_kinds or FAULT_KINDS)
        families |= {FAMILIES[kind] for kind in kinds}
    if not families:
        return "none"
    return families.pop() if len(families) == 1 else "mixed"


def kept(ratios: Sequence[float], keep_below: float = KEEP_BELOW) -> bool:
    """Whether a candidate condition is kept: the median over repertoires of the unchanged best tree's score
    in it, as a fraction of its fault-free score, is below ``keep_below`` (a ratio that is not a number, a
    fault-free score of 0, never keeps it)."""
    values = [r for r in ratios if math.isfinite(r)]
    return bool(values) and len(values) == len(ratios) and float(np.median(values)) < keep_below


def scenario_seeds(purpose: int, count: int, avoid: set[int]) -> list[int]:
    """``count`` scenario seeds derived from ``purpose``, none in ``avoid`` nor repeated (a seed that would
    be is passed over), so the held-out and filter scenarios never meet an adaptation scenario."""
    out: list[int] = []
    k = 0
    while len(out) < count:
        seed = derive_seed(0, purpose, k) & MAX_SEED
        k += 1
        if seed not in avoid and seed not in out:
            out.append(seed)
    return out


class Scores:
    """Mean fitness of homogeneous swarms and of per-robot compositions over a set of scenarios, each
    simulated once: the filter's and the held-out re-scores."""

    def __init__(
        self,
        evaluator: Evaluator,
        local: Evaluator,
        config: Config,
        seeds: Sequence[int],
        trials: int,
        k: int,
    ) -> None:
        self.evaluator, self.local, self.config = evaluator, local, config
        self.seeds, self.trials, self.k = list(seeds), trials, k
        self._cache: dict[tuple[str, ...], float] = {}

    def _mean(self, results: Sequence) -> float:
        values = []
        for result in results:
            if not result.ok:
                raise AdaptationError(f"the evaluator could not evaluate a pick: {result.error}")
            values.append(result.fitness[self.k])
        return float(np.mean(values))

    def homogeneous(self, tree: str) -> float:
        """Mean fitness of every robot running ``tree``."""
        key = (tree,)
        if key not in self._cache:
            requests = [EvaluationRequest(tree, seed, self.trials) for seed in self.seeds]
            self._cache[key] = self._mean(self.evaluator.evaluate(requests))
        return self._cache[key]

    def per_robot(self, base: str, tree: str) -> float:
        """Mean fitness of the swarm where, in each scenario, the robots struck there run ``tree`` and the
        others ``base``."""
        key = ("per-robot", base, tree)
        if key not in self._cache:
            n = self.config.n_robots
            requests = [
                SwarmRequest(composition(base, tree, struck_robots(self.config, seed), n), seed, self.trials)
                for seed in self.seeds
            ]
            self._cache[key] = self._mean(self.local.evaluate(requests))  # type: ignore[arg-type]  # BatchEvaluator takes swarm requests
        return self._cache[key]


@dataclass
class Run:
    """One adaptation run: its trees and fitness in order, what it is measured against, its held-out
    re-scores (at ``EARLY`` trials and at the budget)."""

    method: str
    repertoire: str
    seed: int
    trees: list[str]
    fitness: list[float]
    pre_fault: float
    heldout_pre_fault: float
    heldout_at_10: float = math.nan
    heldout_final: float = math.nan
    stopping_rule: float = math.nan
    floor: float = 0.0
    """The score of a swarm that does nothing useful (``--floor``): fractions count from it."""

    def curve(self, budget: int) -> list[float]:
        """Best so far at every trial up to the budget (a method that stops early keeps its best)."""
        curve = best_so_far(self.fitness)
        return (curve + [curve[-1]] * budget)[:budget]

    def pick(self, trials: int) -> str:
        """The best tree of the first ``trials`` trials (the first on ties)."""
        head = self.fitness[:trials]
        return self.trees[int(np.argmax(head))]

    def trials_to_90(self) -> float:
        bar = self.floor + TARGET * (self.pre_fault - self.floor)
        return trials_to_target(best_so_far(self.fitness), bar)


OUTPUTS = (
    "runs.csv",
    "trials.csv",
    "conditions.csv",
    "ceilings.csv",
    "summary.json",
    "curves.png",
    "report.md",
    "ceiling-checkpoint.json",
)
"""The files the benchmark writes in ``--out`` (the last only while a ceiling's search runs)."""


def benchmark(args: argparse.Namespace) -> dict:
    """Run every method (on the cluster of ``--cluster``); write the files; return the summary."""
    cluster = settings_from_args(args)
    with open_client(cluster, say=lambda line: print(f"adapt-benchmark: {line}", file=sys.stderr)) as client:
        return _benchmark(args, client)


def _one_setting(args: argparse.Namespace) -> RepertoireSetting:
    """The repertoires' shared setting; UsageError naming the first that differs."""
    settings = {str(path): repertoire_setting(path) for path in args.repertoires}
    first_name, first = next(iter(settings.items()))
    for name, setting in settings.items():
        a, b = first.config, setting.config
        for what, mine, theirs in (
            ("model profile", a.profile, b.profile),
            ("task", a.task.name, b.task.name),
            ("library", a.library_digest, b.library_digest),
            ("node set", a.nodes, b.nodes),
        ):
            if mine != theirs:
                raise UsageError(
                    f"the repertoires were evolved in different settings: {first_name} has the {what} "
                    f"{mine or 'none'}, {name} {theirs or 'none'}: give repertoires of one setting"
                )
    return first


def _read_table(path: Path, header: Sequence[str], what: str) -> list[list[str]]:
    if not path.is_file():
        return []
    with path.open(newline="") as handle:
        rows = list(csv.reader(handle))
    if not rows or rows[0] != list(header):
        raise UsageError(f"{path} is not a {what} file of this benchmark: remove it or choose another --out")
    return rows[1:]


def _benchmark(args: argparse.Namespace, client: Client | None) -> dict:
    setting = _one_setting(args)
    profile = setting.config.profile
    task = setting.config.task.name
    args.profile, args.task = profile, task
    args.objective = args.objective or setting.config.objective
    if args.objective not in OBJECTIVES:
        raise UsageError(f"the repertoires' objective {args.objective!r} is none of {', '.join(OBJECTIVES)}")
    if args.ceiling is None:
        args.ceiling = setting.config.evaluations
    args.condition_set = args.condition_set or list(CANDIDATES)
    if args.ceiling_seeds is None or args.ceiling_seeds > args.seeds:
        args.ceiling_seeds = args.seeds
    normal = setting.world
    library = setting.library
    worlds: dict[str, tuple[Config, dict[str, object]]] = {}
    for text in args.condition_set:
        try:
            worlds[text] = apply_conditions(split_condition_set(text), normal)
        except ConditionError as error:
            raise UsageError(f"--condition-set {text}: {error}") from None
    repertoires = {str(path): load_candidates(path, args.objective, library) for path in args.repertoires}
    make_folder(args.out)
    for name in OUTPUTS:  # a link planted at one: refused before the benchmark's minutes, not after them
        refuse_links(args.out / name)
    ceilings_path = args.out / "ceilings.csv"
    ceilings = _read_ceilings(ceilings_path, profile)
    filter_path = args.out / "conditions.csv"
    filtered = {(r[0], r[2]): r for r in _read_table(filter_path, FILTER_HEADER, "conditions")}
    k = OBJECTIVES.index(args.objective)
    seeds = list(range(1, args.seeds + 1))
    filter_seeds = scenario_seeds(_PURPOSE_FILTER, args.filter_scenarios, set(seeds))
    heldout_seeds = scenario_seeds(_PURPOSE_HELDOUT, args.heldout, set(seeds) | set(filter_seeds))
    started = time.monotonic()

    def say(message: str) -> None:
        if not args.no_progress:
            print(
                f"adapt-benchmark [{time.monotonic() - started:6.0f} s]: {message}",
                file=sys.stderr,
                flush=True,
            )

    def evaluator_of(config: Config) -> Evaluator:
        if client is None:
            return BatchEvaluator(config, library=library)
        # Dask (about 0.3 s to import) loads only for a cluster
        from evolution_manager.cluster.evaluator import DaskEvaluator

        return DaskEvaluator(client, config, library=library)

    normal_batch = evaluator_of(normal)
    normal_local = BatchEvaluator(normal, library=library)
    tops = {name: max(candidates, key=lambda c: c.prior) for name, candidates in repertoires.items()}

    # 1. The filter: the unchanged best, fault-free and changed, on fresh scenarios.
    normal_filter = Scores(normal_batch, normal_local, normal, filter_seeds, args.trials, k)
    candidates_summary: dict[str, dict[str, object]] = {}
    for condition, (config, record) in worlds.items():
        family = fault_family(config, record)
        changed = Scores(evaluator_of(config), BatchEvaluator(config, library=library), config, filter_seeds,
                         args.trials, k)  # fmt: skip
        ratios = []
        for name, top in tops.items():
            row = filtered.get((condition, name))
            if row is None or row[3] != str(len(filter_seeds)) or row[-1] != profile:
                say(f"{condition}: filter, {name}")
                free, hit = normal_filter.homogeneous(top.tree), changed.homogeneous(top.tree)
                row = [condition, family, name, str(len(filter_seeds)), f"{free:.6f}", f"{hit:.6f}"]
                row += ["", profile]
                filtered[(condition, name)] = row
                write_atomic(filter_path, _csv_text(FILTER_HEADER, list(filtered.values())))
            # The ratio from the scores as written, counted from this run's floor.
            ratio = relative(float(row[5]), float(row[4]), args.floor)
            row[6] = f"{ratio:.6f}"
            ratios.append(ratio)
        candidates_summary[condition] = {
            "family": family,
            "conditions": record,
            "ratios": ratios,
            "median_ratio": float(np.median(ratios)),
            "kept": kept(ratios, args.keep_below),
        }
    write_atomic(filter_path, _csv_text(FILTER_HEADER, list(filtered.values())))
    chosen = [c for c in worlds if candidates_summary[c]["kept"]]
    say(f"kept {len(chosen)} of {len(worlds)} candidate conditions: {', '.join(chosen) or 'none'}")

    # 2. The methods on every kept condition.
    runs: dict[str, list[Run]] = {}
    ceiling_of: dict[tuple[str, int], float] = {}
    normal_heldout = Scores(normal_batch, normal_local, normal, heldout_seeds, args.trials, k)
    normal_scenario = {s: ConditionEvaluation(normal_local, s, args.trials) for s in seeds}
    for condition in chosen:
        config = worlds[condition][0]
        batch = evaluator_of(config)
        local = BatchEvaluator(config, library=library)
        heldout = Scores(batch, local, config, heldout_seeds, args.trials, k)
        found = runs.setdefault(condition, [])
        for seed in seeds:
            evaluate = ConditionEvaluation(batch, seed, args.trials)
            best_ceiling = -math.inf if seed <= args.ceiling_seeds else math.nan
            for algorithm in ("qd", "gp") if seed <= args.ceiling_seeds else ():
                key = (condition, seed, algorithm)
                if key not in ceilings:
                    checkpoint = SearchCheckpoint(
                        args.out / "ceiling-checkpoint.json",
                        {"condition": condition, "seed": seed, "algorithm": algorithm, "task": task,
                         "objective": args.objective, "evaluations": args.ceiling, "trials": args.trials,
                         "profile": profile},
                    )  # fmt: skip
                    saved = saved_search(checkpoint)
                    done = saved.get("trees") if saved else None
                    again = f", from its checkpoint at {len(done)}" if isinstance(done, list) else ""
                    say(f"{condition} seed {seed}: ceiling, {algorithm}, {args.ceiling} evaluations{again}")
                    run_eval = ConditionEvaluation(batch, seed, args.trials)
                    trees, fitness = reevolve(
                        algorithm, args.objective, args.ceiling, seed, run_eval, setting, checkpoint
                    )
                    best = int(np.argmax(fitness))
                    ceilings[key] = [
                        condition,
                        str(seed),
                        algorithm,
                        str(len(fitness)),
                        str(run_eval.simulated),
                    ]
                    ceilings[key] += [f"{fitness[best]:.6f}", trees[best], profile]
                    write_atomic(ceilings_path, _csv_text(CEILING_HEADER, list(ceilings.values())))
                    checkpoint.path.unlink(missing_ok=True)  # the ceiling is in ceilings.csv now
                best_ceiling = max(best_ceiling, float(ceilings[key][5]))
            ceiling_of[(condition, seed)] = best_ceiling
            say(f"{condition} seed {seed}: ceiling {best_ceiling:.4f}; the methods")
            pre = {name: normal_scenario[seed]([top.tree])[0].objective(k) for name, top in tops.items()}
            pre_heldout = {name: normal_heldout.homogeneous(top.tree) for name, top in tops.items()}

            for n, algorithm in enumerate(("qd", "gp")):
                # Own seeds: with the same seed both would draw the same initial random trees.
                own = derive_seed(seed, _PURPOSE_SCRATCH, n) & MAX_SEED
                trees, fitness = reevolve(algorithm, args.objective, args.budget, own, evaluate, setting)
                means = (float(np.mean(list(pre.values()))), float(np.mean(list(pre_heldout.values()))))
                run = Run(f"{algorithm}-scratch", "", seed, trees, fitness, *means)
                found.append(_rescored(run, heldout.homogeneous, args.budget, args.floor))
            for r, (name, candidates) in enumerate(repertoires.items()):
                top = tops[name]
                reference = (pre[name], pre_heldout[name])
                value = evaluate([top.tree])[0].objective(k)
                run = Run("unchanged", name, seed, [top.tree], [value], *reference)
                found.append(_rescored(run, heldout.homogeneous, args.budget, args.floor))
                ite = IntelligentTrialAndError(candidates, args.budget, ITEParameters(stop_fraction=None))
                run_picker(ite, evaluate, args.objective)
                run = _picked("ite", name, seed, ite.tried, reference)
                run.stopping_rule = _stopping_rule(ite.tried)
                found.append(_rescored(run, heldout.homogeneous, args.budget, args.floor))
                per_robot = IntelligentTrialAndError(
                    candidates, args.budget, ITEParameters(stop_fraction=None)
                )
                run_picker(per_robot, CompositionEvaluation(local, config, seed, top.tree, args.trials),
                           args.objective)  # fmt: skip
                run = _picked("ite-per-robot", name, seed, per_robot.tried, reference)
                run.stopping_rule = _stopping_rule(per_robot.tried)
                found.append(
                    _rescored(run, functools.partial(heldout.per_robot, top.tree), args.budget, args.floor)
                )
                seed_random = derive_seed(seed, _PURPOSE_RANDOM, r) & MAX_SEED
                picks = RandomPicks(candidates, args.budget, seed_random)
                run_picker(picks, evaluate, args.objective)
                run = _picked("random", name, seed, picks.tried, reference)
                found.append(_rescored(run, heldout.homogeneous, args.budget, args.floor))

    write_atomic(args.out / "runs.csv", _csv_text(RUN_HEADER, run_rows(runs, task, args.budget)))
    write_atomic(args.out / "trials.csv", _csv_text(TRIAL_HEADER, trial_rows(runs, task, args.budget)))
    summary = summarise(candidates_summary, runs, ceiling_of, args)
    write_json(args.out / "summary.json", summary)
    curves_figure(summary, runs, args.out / "curves.png", args.objective, args.budget)
    write_atomic(args.out / "report.md", report_text(summary, args))
    say(f"done: {args.out / 'report.md'}")
    return summary


def _rescored(run: Run, rescore: Callable[[str], float], budget: int, floor: float) -> Run:
    """``run`` with its picks (at ``EARLY`` trials and at the budget) re-scored by ``rescore``, its fractions
    counted from ``floor``."""
    run.floor = floor
    run.heldout_at_10 = rescore(run.pick(EARLY))
    run.heldout_final = rescore(run.pick(budget))
    return run


def _picked(
    method: str, repertoire: str, seed: int, tried: Sequence[Tried], reference: tuple[float, float]
) -> Run:
    return Run(method, repertoire, seed, [t.tree for t in tried], [t.fitness for t in tried], *reference)


def _stopping_rule(tried: Sequence[Tried]) -> float:
    """The trial where ITE's stopping rule (best observed >= 0.9 x the highest expected fitness) stops."""
    for n in range(len(tried)):
        if max(t.fitness for t in tried[: n + 1]) >= TARGET * tried[n].expected_max:
            return float(n + 1)
    return math.inf


def _number(value: float) -> str:
    return "" if not math.isfinite(value) else f"{value:.6f}"


def run_rows(runs: dict[str, list[Run]], task: str, budget: int) -> list[list[object]]:
    """``runs.csv``'s rows (``RUN_HEADER``): ``trials_to_90`` empty where the run never got there."""
    rows: list[list[object]] = []
    for condition, found in runs.items():
        for run in found:
            hit = run.trials_to_90()
            stop = run.stopping_rule
            rows.append(
                [
                    *(run.method, task, condition, run.seed, run.repertoire),
                    "" if math.isinf(hit) else int(hit),
                    *(_number(run.heldout_final), _number(run.heldout_at_10), _number(run.heldout_pre_fault)),
                    *(_number(run.pre_fault), _number(run.curve(budget)[-1])),
                    "" if not math.isfinite(stop) else int(stop),
                ]
            )
    return rows


def trial_rows(runs: dict[str, list[Run]], task: str, budget: int) -> list[list[object]]:
    """``trials.csv``'s rows: every trial of every run (the unchanged tree: its one trial)."""
    rows: list[list[object]] = []
    for condition, found in runs.items():
        for run in found:
            curve = best_so_far(run.fitness)
            for trial, (tree, value, best) in enumerate(zip(run.trees, run.fitness, curve, strict=True), 1):
                rows.append([task, condition, run.method, run.repertoire, run.seed, trial, tree])
                rows[-1] += [f"{value:.6f}", f"{best:.6f}"]
    return rows


def relative(value: float, reference: float, floor: float = 0.0) -> float:
    """``value`` as a fraction of ``reference``, both counted from ``floor``; nan where the reference is at
    the floor or below it."""
    return (value - floor) / (reference - floor) if reference > floor else math.nan


def _median(values: Sequence[float]) -> float:
    """The median of the values that are numbers (infinity, never reached, is one); nan for none."""
    data = np.asarray(values, dtype=np.float64)
    data = data[~np.isnan(data)]
    return float(np.median(data)) if len(data) else math.nan


def method_summary(found: Sequence[Run], budget: int, ceiling_of: dict[int, float] | None = None) -> dict:
    """Per method over ``found``: trials to 90 % of the pre-fault score (median, never as infinity), the
    fraction recovered within ``RECOVERED_AT`` trials (None beyond the budget), the held-out re-scores as a
    fraction of the best tree's fault-free held-out score (median) and the share of the loss regained."""
    out: dict[str, dict] = {}
    for method in METHODS:
        mine = [run for run in found if run.method == method]
        if not mine:
            continue
        hits = [run.trials_to_90() for run in mine]
        data: dict[str, object] = {
            "runs": len(mine),
            "median_trials_to_90": _median(hits),
            "reached": sum(math.isfinite(h) for h in hits),
            "median_best_at_budget_fraction": _median(
                [relative(r.curve(budget)[-1], r.pre_fault, r.floor) for r in mine]
            ),
            "median_heldout_final_fraction": _median(
                [relative(r.heldout_final, r.heldout_pre_fault, r.floor) for r in mine]
            ),
            "median_heldout_at_10_fraction": _median(
                [relative(r.heldout_at_10, r.heldout_pre_fault, r.floor) for r in mine]
            ),
        }
        for at in RECOVERED_AT:
            data[f"recovered_at_{at}"] = None if at > budget else sum(h <= at for h in hits) / len(hits)
        if ceiling_of is not None:
            data["median_fraction_of_ceiling"] = _median(
                [relative(r.curve(budget)[-1], ceiling_of[r.seed], r.floor) for r in mine]
            )
        out[method] = data
    # The loss regained on the held-out scenarios, against the unchanged tree there (SMBO's kind of measure).
    unchanged = {(r.repertoire, r.seed): r.heldout_final for r in found if r.method == "unchanged"}
    for method, data in out.items():
        regained = [
            (r.heldout_final - unchanged[(r.repertoire, r.seed)])
            / (r.heldout_pre_fault - unchanged[(r.repertoire, r.seed)])
            for r in found
            if r.method == method
            and (r.repertoire, r.seed) in unchanged
            and r.heldout_pre_fault > unchanged[(r.repertoire, r.seed)]
        ]
        data["median_heldout_loss_regained"] = _median(regained)
    return out


def summarise(
    candidates: dict[str, dict[str, object]],
    runs: dict[str, list[Run]],
    ceiling_of: dict[tuple[str, int], float],
    args: argparse.Namespace,
) -> dict:
    """The candidates and which were kept; per fault family and per kept condition, every method's measures
    (``method_summary``)."""
    out: dict[str, object] = {
        "task": args.task,
        "objective": args.objective,
        "profile": args.profile,
        "budget": args.budget,
        "seeds": args.seeds,
        "ceiling_evaluations": args.ceiling,
        "ceiling_seeds": args.ceiling_seeds,
        "keep_below": args.keep_below,
        "floor": args.floor,
        "filter_scenarios": args.filter_scenarios,
        "heldout_scenarios": args.heldout,
        "candidates": candidates,
    }
    families: dict[str, dict[str, object]] = {}
    for name in dict.fromkeys(str(data["family"]) for data in candidates.values()):  # in candidate order
        members = [c for c, data in candidates.items() if str(data["family"]) == name]
        kept = [c for c in members if candidates[c]["kept"]]
        families[name] = {
            "candidates": len(members),
            "kept": len(kept),
            "conditions": kept,
            "methods": method_summary([run for c in kept for run in runs.get(c, [])], args.budget),
        }
    out["families"] = families
    out["conditions"] = {
        condition: {
            "family": candidates[condition]["family"],
            "ceiling_median": _median([ceiling_of[(condition, s)] for s in range(1, args.seeds + 1)]),
            "methods": method_summary(
                found, args.budget, {s: ceiling_of[(condition, s)] for s in range(1, args.seeds + 1)}
            ),
        }
        for condition, found in runs.items()
    }
    every = [run for found in runs.values() for run in found]
    out["all"] = method_summary(every, args.budget) if every else {}
    finite = _finite(out)
    assert isinstance(finite, dict)
    return finite


def _finite(data: object) -> object:
    """Infinity (never reached) and not-a-number as None, for strict JSON."""
    if isinstance(data, dict):
        return {k: _finite(v) for k, v in data.items()}
    if isinstance(data, list | tuple):
        return [_finite(v) for v in data]
    if isinstance(data, float) and not math.isfinite(data):
        return None
    return data


def curves_figure(summary: dict, runs: dict[str, list[Run]], path: Path, objective: str, budget: int) -> Path:
    """One panel per kept condition: median best-so-far as a fraction of the pre-fault score against trials
    used, per method, with the 90 % line (one empty panel saying so where no condition was kept)."""
    # matplotlib (about 1.5 s to import) loads only when figures are drawn
    from evolution_manager.viewing import figures

    conditions = list(runs) or ["no condition kept"]
    columns = min(3, len(conditions))
    rows = math.ceil(len(conditions) / columns)
    figure, axes = figures.subplots(rows, columns, figsize=(5.0 * columns, 3.6 * rows), squeeze=False)
    for axis, condition in zip(axes.flat, conditions, strict=False):
        for method in METHODS:
            mine = [r for r in runs.get(condition, []) if r.method == method]
            if not mine:
                continue
            data = np.array([(np.array(r.curve(budget)) - r.floor) / (r.pre_fault - r.floor) for r in mine])
            x = np.arange(1, budget + 1)
            axis.plot(x, np.median(data, axis=0), label=LABELS[method], drawstyle="steps-post")
            axis.fill_between(
                x, np.percentile(data, 25, axis=0), np.percentile(data, 75, axis=0), alpha=0.15, step="post"
            )
        axis.axhline(TARGET, color="k", linestyle="--", linewidth=1, label="90 % of the pre-fault score")
        axis.set_title(condition, fontsize=10)
        axis.set_xlabel("trials used (evaluations)")
        axis.set_ylabel(f"best {objective} so far / pre-fault")
    for axis in list(axes.flat)[len(conditions) :]:
        axis.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    if handles:
        figure.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, bbox_to_anchor=(0.5, -0.02))
    figure.tight_layout(rect=(0, 0.24 / rows, 1, 1))  # about 0.85 inch under the panels for the legend
    return figures._save(figure, path)


def _trials(value: float | None, budget: int) -> str:
    return f"never in {budget}" if value is None else f"{value:g}"


def _percent(value: float | None) -> str:
    return "n/a" if value is None else f"{100 * value:.0f} %"


def _method_lines(label: str, methods: dict, budget: int) -> list[str]:
    lines = []
    for method in METHODS:
        if method not in methods:
            continue
        m = methods[method]
        ceiling = (
            f" {_percent(m['median_fraction_of_ceiling'])} |" if "median_fraction_of_ceiling" in m else ""
        )
        lines.append(
            f"| {label} | {LABELS[method]} | {m['runs']} | {_trials(m['median_trials_to_90'], budget)} | "
            f"{_percent(m['recovered_at_10'])} | {_percent(m['recovered_at_30'])} | "
            f"{_percent(m['median_heldout_at_10_fraction'])} | "
            f"{_percent(m['median_heldout_final_fraction'])} |{ceiling}"
        )
    return lines


def report_text(summary: dict, args: argparse.Namespace) -> str:
    """``report.md``: how it was made, which conditions were kept, the tables per fault family and per
    condition, per robot against per swarm, and SMBO's figure beside ours."""
    command = " ".join(
        ["ws/run evolution_manager adapt-benchmark", "--repertoires", *(str(r) for r in args.repertoires)]
        + [f"--objective {args.objective}"]
        + [f"--condition-set {c}" for c in args.condition_set]
        + [f"--seeds {args.seeds} --budget {args.budget} --ceiling {args.ceiling} --trials {args.trials}"]
        + [f"--ceiling-seeds {args.ceiling_seeds}"]
        + [
            f"--keep-below {args.keep_below:g} --floor {args.floor:g} "
            f"--filter-scenarios {args.filter_scenarios}"
        ]
        + [f"--heldout {args.heldout} --out {args.out}"]
    )
    budget = summary["budget"]
    lines = [
        f"# Adaptation on harder conditions: task {summary['task']}, objective {summary['objective']}",
        "",
        f"Model profile `{summary['profile']}` (the repertoires'); {len(args.repertoires)} repertoires x "
        f"{args.seeds} seeds per kept condition; budget {budget} trials (one trial = one evaluation of "
        f"{args.trials} simulated trials in the changed world, every evaluation of a seed on the same "
        "scenario). A candidate condition is kept where the repertoire's best tree, unchanged, keeps less "
        f"than {100 * args.keep_below:g} % of its fault-free score on {args.filter_scenarios} fresh "
        "scenarios (median over the repertoires). The pre-fault score: the best tree's score without the "
        f"condition on the same scenario. Each method's pick (best so far at {EARLY} trials and at the "
        f"budget) is re-scored on {args.heldout} held-out scenarios, beside the best tree's fault-free score "
        f"there. Every fraction counts from a floor of {args.floor:g} (the score of a swarm that does "
        "nothing useful: 0 for a count, 0.5 for the food, nest and density primitives, whose fitness is "
        "0.5 when the estimate never changes). Made by:",
        "",
        f"    {command}",
        "",
        "Files: `runs.csv` (one row per method, task, condition, seed and repertoire), `trials.csv` (every "
        "trial), `conditions.csv` (every candidate's filter scores), `ceilings.csv`, `summary.json`, "
        "`curves.png`.",
        "",
        "![median best so far over the pre-fault score against trials used, interquartile range shaded]"
        "(curves.png)",
        "",
        "## Conditions kept",
        "",
        "| fault family | candidates | kept |",
        "|---|---|---|",
    ]
    for family, data in summary["families"].items():
        lines.append(f"| {family} | {data['candidates']} | {data['kept']} |")
    lines += ["", "| candidate | family | unchanged / fault-free (median) | kept |", "|---|---|---|---|"]
    for condition, data in summary["candidates"].items():
        ratio = data["median_ratio"]
        shown = "n/a" if ratio is None else f"{100 * ratio:.1f} %"
        lines.append(f"| {condition} | {data['family']} | {shown} | {'yes' if data['kept'] else 'no'} |")
    header = [
        "| {what} | method | runs | median trials to 90 % of pre-fault | recovered within 10 | within 30 | "
        "held-out at 10 (% of pre-fault) | held-out at the budget |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += [
        "",
        "## Per fault family",
        "",
        "Median over runs (a run that never gets there counts as never); recovered: the fraction of runs "
        "whose best so far reaches 90 % of the pre-fault score within 10 and 30 trials; held-out: the pick "
        "re-scored on the held-out scenarios over the best tree's fault-free score there (median).",
        "",
        header[0].format(what="family"),
        header[1],
    ]
    for family, data in summary["families"].items():
        lines += _method_lines(family, data["methods"], budget)
    lines += [
        "",
        "## Per condition",
        "",
        "With the best so far at the budget as a fraction of the ceiling (the best that MAP-Elites or GP_o "
        f"found from scratch in the changed world with {args.ceiling} evaluations, seeds "
        f"1-{args.ceiling_seeds}): what the changed world still allows, where 90 % of the pre-fault score "
        "is out of reach.",
        "",
        header[0].format(what="condition") + " best at budget, % of ceiling |",
        header[1] + "---|",
    ]
    for condition, data in summary["conditions"].items():
        lines += _method_lines(condition, data["methods"], budget)
    every = summary["all"]
    lines += ["", "## Per robot against per swarm", ""]
    if "ite-per-robot" in every and "ite" in every:
        for family, data in summary["families"].items():
            m = data["methods"]
            if "ite" in m and "ite-per-robot" in m:
                robot, swarm = m["ite-per-robot"], m["ite"]
                lines.append(
                    f"- {family}: median trials to 90 % {_trials(robot['median_trials_to_90'], budget)} per "
                    f"robot, {_trials(swarm['median_trials_to_90'], budget)} per swarm; held-out at the "
                    f"budget {_percent(robot['median_heldout_final_fraction'])} against "
                    f"{_percent(swarm['median_heldout_final_fraction'])}"
                )
    else:
        lines.append("- no condition was kept: nothing to compare")
    lines += ["", "## Beside SMBO", "", f"- {SMBO_FIGURE}."]
    for method in ("ite", "ite-per-robot"):
        if method in every:
            m = every[method]
            lines.append(
                f"- ours, {LABELS[method]}, every kept condition: median share of the loss at the fault "
                f"regained on the held-out scenarios at the budget ({budget} trials) "
                f"{_percent(m['median_heldout_loss_regained'])}; runs at 90 % of the pre-fault score within "
                f"30 trials {_percent(m['recovered_at_30'])}, within 10 {_percent(m['recovered_at_10'])}."
            )
    lines += [
        "",
        "The goal: on kept conditions, a median recovery to at least 90 % of the pre-fault score on fresh "
        f'scenarios within {EARLY} trials; the column "held-out at 10" gives it.',
    ]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point of ``adapt-benchmark``."""
    try:
        args = build_parser().parse_args(argv)
        benchmark(args)
    except (UsageError, AdaptationError, ClusterError) as error:
        print(f"adapt-benchmark: error: {error}", file=sys.stderr)
        sys.exit(EXIT_USAGE)
    except DispatchError as error:  # the cluster's workers could not finish a chunk
        print(
            f"adapt-benchmark: error: {error}; the filter's scores and the ceilings found so far are kept",
            file=sys.stderr,
        )
        sys.exit(1)
    except (WriteError, OSError) as error:  # a link planted in --out, a full disk, a read-only folder
        print(f"adapt-benchmark: error: {error}", file=sys.stderr)
        sys.exit(EXIT_IO)
    sys.exit(0)
