"""``adapt``: recover from damage or a changed world by searching a repertoire (Intelligent Trial and Error).

    ws/run evolution_manager adapt --repertoire RUN_DIR --objective food --condition dead-robots=3 \\
        --budget 20 --out DIR [--seed S] [--trials 10] [--graph | --per-robot] [--no-stop]

Each adaptation trial evaluates one tree of the repertoire in the changed world (``--condition``, repeatable:
``swarm_sim.model.conditions``), every tree on the same scenario (``--seed``), so ``ws/run swarm_sim evaluate
--tree T --seed S --condition ...`` reproduces any fitness it reports. ``--graph`` runs each trial through the
node graph instead (the simulator node in the changed world and one controller node per robot, each tree
loaded with ``load_tree``, a library's primitives written out in it), recording every simulated trial to a
bag under ``DIR/bags/``; it chooses the same tree with the same fitness as the batch road. ``--per-robot``
adapts only the robots the condition strikes (``search.CompositionEvaluation``: they share the tried tree,
the others keep the repertoire's best). The changed world is the repertoire's own on every road (its task
under its profile, its trees built with its library), so a foraging repertoire adapts as a primitive's does.

Writes ``DIR/adaptation.json`` (the chosen ``tree`` and its ``fitness``, ``tried``: every tried tree with its
fitness in order, ``seed``, ``conditions``, why it stopped, the parameters) and ``DIR/adaptation.png`` (the
curve). Bad options print one line and exit with status 2; an ``--out`` that already holds an adaptation is
never overwritten.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from evolution_manager.adaptation.search import (
    AdaptationError,
    Candidate,
    CompositionEvaluation,
    ConditionEvaluation,
    IntelligentTrialAndError,
    ITEParameters,
    Tried,
    load_candidates,
    repertoire_setting,
    run_picker,
    written_out,
)
from evolution_manager.arguments import EXIT_IO, EXIT_USAGE, Parser, positive_int, seed_int
from evolution_manager.errors import EvolutionError, UsageError, WriteError
from evolution_manager.evolution.run_config import OBJECTIVES
from evolution_manager.files import write_json
from swarm_ros.safe_paths import refuse_links
from swarm_sim.errors import ConditionError
from swarm_sim.evaluation import BatchEvaluator
from swarm_sim.model import apply_conditions

RESULT = "adaptation.json"
FIGURE = "adaptation.png"


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    return value


def build_parser() -> argparse.ArgumentParser:
    """The ``adapt`` command line."""
    parser = Parser(prog="adapt", description=__doc__.split("\n")[0])
    parser.add_argument("--repertoire", type=Path, required=True, help="a run directory holding repertoires")
    parser.add_argument("--objective", choices=OBJECTIVES, required=True, help="the objective to recover")
    parser.add_argument(
        "--condition",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="changed world (repeatable): dead-robots=K, weak-wheel=K:GAIN, message-loss=P, robots=N, "
        "gap=MM, food-disc=R, faults=RATE[:KIND,KIND]|FILE",
    )
    parser.add_argument("--budget", type=positive_int, default=20, help="most trials (default 20)")
    parser.add_argument(
        "--out", type=Path, required=True, help="output directory (must not hold an adaptation)"
    )
    parser.add_argument("--seed", type=seed_int, default=0, help="scenario seed of every trial (default 0)")
    parser.add_argument(
        "--trials", type=positive_int, default=10, help="simulated trials per evaluation (10)"
    )
    parser.add_argument(
        "--graph", action="store_true", help="run every trial through the node graph, recorded"
    )
    parser.add_argument(
        "--per-robot",
        action="store_true",
        help="change only the struck robots' tree (the others keep theirs)",
    )
    parser.add_argument("--no-stop", action="store_true", help="spend the whole budget (no stopping rule)")
    defaults = ITEParameters()
    parser.add_argument("--stop-fraction", type=_fraction, default=defaults.stop_fraction, help="alpha (0.9)")
    parser.add_argument("--kappa", type=_fraction, default=defaults.kappa, help="UCB exploration (0.05)")
    parser.add_argument("--length-scale", type=_fraction, default=defaults.length_scale, help="GP (0.25)")
    return parser


def tried_record(t: Tried, number: int) -> dict[str, object]:
    """One entry of ``tried``."""
    return {
        "trial": number,
        "bin": list(t.bin),
        "tree": t.tree,
        "prior": t.prior,
        "fitness": t.fitness,
        "descriptors": list(t.descriptors),
        "expected_max": None if math.isnan(t.expected_max) else t.expected_max,
    }


def adaptation_document(
    search: IntelligentTrialAndError,
    candidates: Sequence[Candidate],
    *,
    repertoire: Path,
    objective: str,
    conditions: dict[str, object],
    profile: str,
    seed: int,
    trials: int,
    road: str,
    robots: Sequence[int] | None = None,
) -> dict[str, object]:
    """The content of ``adaptation.json`` (``robots``: the robots a per-robot adaptation changed, None
    for every robot)."""
    best = search.best
    assert best is not None
    top = max(candidates, key=lambda c: c.prior)
    return {
        "tree": best.tree,
        "fitness": best.fitness,
        "bin": list(best.bin),
        "objective": objective,
        "conditions": conditions,
        "profile": profile,
        "seed": seed,
        "trials_per_evaluation": trials,
        "road": road,
        "robots": None if robots is None else list(robots),
        "repertoire": str(repertoire),
        "bins": len(candidates),
        "repertoire_best": {"tree": top.tree, "prior": top.prior, "bin": list(top.bin)},
        "budget": search.budget,
        "trials_used": len(search.tried),
        "stopped": search.stop_reason,
        "parameters": search.parameters.as_dict(),
        "tried": [tried_record(t, k + 1) for k, t in enumerate(search.tried)],
    }


def adaptation_figure(document: dict, path: Path) -> Path:
    """Fitness of every trial and the best so far, against trials used; the tried trees' priors for
    comparison."""
    # matplotlib (about 1.5 s to import) loads only when figures are drawn
    from evolution_manager.viewing import figures

    tried = document["tried"]
    x = [t["trial"] for t in tried]
    fitness = [t["fitness"] for t in tried]
    best = [max(fitness[: k + 1]) for k in range(len(fitness))]
    figure, axis = figures.subplots(figsize=(6.4, 4.0), constrained_layout=True)
    axis.plot(x, [t["prior"] for t in tried], "x", color="0.6", label="prior (repertoire fitness)")
    axis.plot(x, fitness, "o", color="tab:blue", label="fitness in the changed world")
    axis.step(x, best, where="post", color="tab:red", label="best so far")
    conditions = ", ".join(f"{k}={v}" for k, v in document["conditions"].items()) or "no condition"
    axis.set_title(f"{document['objective']}: {conditions}", fontsize=10)
    axis.set_xlabel("adaptation trials (evaluations)")
    axis.set_ylabel(f"{document['objective']} fitness")
    axis.set_xlim(0.5, max(document["budget"], len(x)) + 0.5)
    axis.legend(fontsize=8, loc="lower right")
    return figures._save(figure, path)


def adapt(argv: Sequence[str] | None = None) -> int:
    """Run ``adapt``; return the exit status."""

    try:
        args = build_parser().parse_args(argv)
        setting = repertoire_setting(args.repertoire)
        profile = setting.config.profile
        if args.graph and args.per_robot:
            raise UsageError("--per-robot runs on the batch road only: drop --graph or --per-robot")
        try:
            config, conditions = apply_conditions(args.condition, setting.world)
        except ConditionError as error:
            raise UsageError(f"--condition: {error}") from None
        stop = None if args.no_stop else args.stop_fraction
        try:
            parameters = ITEParameters(args.length_scale, kappa=args.kappa, stop_fraction=stop)
        except EvolutionError as error:
            raise UsageError(str(error)) from None
        candidates = load_candidates(args.repertoire, args.objective, setting.library)
        if args.graph:  # the controller nodes read no library: the primitives go to them written out
            candidates = written_out(candidates, setting.library)
        for name in (RESULT, FIGURE):  # a planted link is refused before any trial, never written through
            try:
                refuse_links(args.out / name)
            except OSError as error:
                raise UsageError(str(error)) from None
        if (args.out / RESULT).exists():
            raise UsageError(f"{args.out} already holds an adaptation ({RESULT}): choose another --out")
        if not 0 <= args.seed <= 2**63 - 1:
            raise UsageError(f"--seed must be in [0, 2**63 - 1], got {args.seed}")
        args.out.mkdir(parents=True, exist_ok=True)
    except (UsageError, AdaptationError) as error:
        print(f"adapt: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:
        print(f"adapt: error: {args.out}: {error.strerror or error}", file=sys.stderr)
        return EXIT_USAGE

    search = IntelligentTrialAndError(candidates, args.budget, parameters)
    robots = None

    def show(t: Tried) -> None:
        number = len(search.tried)
        print(
            f"adapt: trial {number}/{args.budget}: bin {list(t.bin)} prior {t.prior:.4f} -> "
            f"{t.fitness:.4f} (best {search.best.fitness:.4f})",  # type: ignore[union-attr]  # set after a trial
            file=sys.stderr,
            flush=True,
        )

    if args.graph:
        # rclpy: adaptation is ROS-free but --graph
        from evolution_manager.graph.graph_evaluator import graph_evaluator

        bags, task = args.out / "bags", setting.config.task
        with graph_evaluator(args.condition, bags, profile=profile, task=task) as graph:
            run_picker(search, ConditionEvaluation(graph, args.seed, args.trials), args.objective, show)
    elif args.per_robot:
        top = max(candidates, key=lambda c: c.prior)
        batch = BatchEvaluator(config, library=setting.library)
        swarms = CompositionEvaluation(batch, config, args.seed, top.tree, args.trials)
        robots = swarms.robots
        run_picker(search, swarms, args.objective, show)
    else:
        evaluate = ConditionEvaluation(
            BatchEvaluator(config, library=setting.library), args.seed, args.trials
        )
        run_picker(search, evaluate, args.objective, show)
    document = adaptation_document(
        search,
        candidates,
        repertoire=args.repertoire,
        objective=args.objective,
        conditions=conditions,
        profile=profile,
        seed=args.seed,
        trials=args.trials,
        road="graph" if args.graph else "batch",
        robots=robots,
    )
    try:
        write_json(args.out / RESULT, document)
        adaptation_figure(document, args.out / FIGURE)
    except WriteError as error:  # a full disk, a link planted meanwhile: one line
        print(f"adapt: error: {error}", file=sys.stderr)
        return EXIT_IO
    print(
        f"adapt: {document['trials_used']} trials ({document['stopped']}); chose bin {document['bin']} "
        f"with {args.objective} {document['fitness']:.4f}; wrote {args.out / RESULT}"
    )
    return 0


def main() -> None:
    """Console entry point of ``adapt``."""
    sys.exit(adapt())
