"""``ws/run swarm_sim evaluate``: evaluate one tree, or a swarm of a tree per robot; print one JSON object.

    evaluate (--tree TREE | --network FILE | --swarm FILE) [--trials 10] [--seed S] [--profile paper|clean]
             [--task NAME|FILE] [--engine compiled|reference] [--per-trial]
             [--condition NAME=VALUE ...] [--library FILE]

Prints ``{"tree", "seed", "trials", "profile", "task", "conditions", "fitness": {every objective},
"descriptors": {movement, rotation, conditionality}}`` (``conditions``: the world's changes,
``swarm_sim.model.conditions``, ``{}`` for none; ``task``: the task's name (``primitives``, 20 s trials, or
``foraging``, 100 s trials) or, for a task file's or an edited task, every key of it (``swarm_sim.tasks``);
``"per_trial"`` added with ``--per-trial``: each
trial's values, gap and the robots' start and end poses as [x, y, heading]). The tree is printed in canonical
form. With ``--library FILE`` (a primitive library, ``bt_controller.language.library``) the tree may name its
primitives, each use its own ``success`` copy; the tree is printed with the names, and ``"library": {"file",
"digest"}`` is added. ``--swarm FILE`` (a swarm layout, ``swarm_sim.model.swarm_layout``: ``{"trees": [one
tree text per robot]}`` or ``{"tree": TREE}``) gives each robot its own tree; ``"trees"`` (each robot's tree,
robot 0 first, canonical) then stands in place of ``"tree"``. ``--network FILE`` (``{"weights": [56
numbers]}``, ``bt_controller.interpreters.network``) runs that network on every robot instead of a tree;
``"network"`` (its 56 weights) then stands in place of ``"tree"``. Bad input: one line on stderr, exit status
2.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from typing import NoReturn

from bt_controller.draws import MAX_SEED
from bt_controller.interpreters import (
    Network,
    NetworkError,
    controller_text,
    is_network_text,
    load_network,
    parse_network,
)
from bt_controller.language import Library, Node, library_option
from bt_controller.model_settings import PROFILES
from swarm_sim.core import TrialRecord
from swarm_sim.errors import ConditionError, UsageError
from swarm_sim.evaluation.batch import (
    MAX_TRIALS,
    BatchEvaluator,
    EvaluationRequest,
    SwarmRequest,
    check_request,
)
from swarm_sim.model import (
    CONDITION_NAMES,
    DEFAULT,
    DESCRIPTORS,
    OBJECTIVES,
    VALUE_NAMES,
    LayoutError,
    apply_conditions,
    load_layout,
)
from swarm_sim.tasks import DEFAULT_TASK, TaskSpec, add_task_option, task_named, task_to_record

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="evaluate", description="Evaluate one behaviour tree or a swarm layout; print one JSON object."
    )
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--tree", help="tree text for every robot, e.g. 'sel(seq(in_nest, stop), forward)'")
    what.add_argument(
        "--network",
        metavar="FILE",
        help='a network for every robot: a JSON file {"weights": [56 numbers]} (9-5-1 perceptron)',
    )
    what.add_argument(
        "--swarm",
        metavar="FILE",
        help='a tree per robot: a JSON file {"trees": ["tree text", ...]} (one per robot, robot 0 first)',
    )
    parser.add_argument("--trials", type=int, default=10, help="number of trials (default 10)")
    parser.add_argument("--seed", type=int, default=0, help=f"seed in [0, {MAX_SEED}] (default 0)")
    parser.add_argument(
        "--profile",
        choices=PROFILES,
        default=DEFAULT.profile,
        help=f"the model's profile (docs/model.md): the authors' experiment or without its artefacts "
        f"(default {DEFAULT.profile})",
    )
    add_task_option(parser)
    parser.add_argument(
        "--engine",
        choices=("compiled", "reference"),
        default="compiled",
        help="batch kernels (default) or the reference road",
    )
    parser.add_argument("--per-trial", action="store_true", help="add each trial's values and poses")
    parser.add_argument(
        "--condition",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help=f"change the world (repeatable): {', '.join(CONDITION_NAMES)}; e.g. dead-robots=2",
    )
    parser.add_argument(
        "--library",
        metavar="FILE",
        help="a primitive library (JSON): the tree may use its primitives' names",
    )
    return parser


def evaluation_json(
    tree_text: str | Sequence[str],
    seed: int,
    trials: int,
    values: Sequence[float],
    records: Sequence[TrialRecord] | None,
    profile: str = DEFAULT.profile,
    conditions: dict[str, object] | None = None,
    library: Library | None = None,
    task: TaskSpec | None = None,
) -> str:
    """The one-line JSON document ``evaluate`` prints (``tree_text`` a sequence: each robot's tree, as
    ``trees``; a network's text: its weights, as ``network``; ``records`` given: with ``per_trial``;
    ``library`` given: with ``library``)."""
    named = dict(zip(VALUE_NAMES, (float(v) for v in values), strict=True))
    which: dict[str, object]
    if isinstance(tree_text, str):
        network = is_network_text(tree_text)
        which = {"network": list(parse_network(tree_text).weights)} if network else {"tree": tree_text}
    else:
        which = {"trees": list(tree_text)}
    document: dict[str, object] = {
        **which,
        "seed": seed,
        "trials": trials,
        "profile": profile,
        "task": task_to_record(task_named(DEFAULT_TASK) if task is None else task),
        "conditions": dict(conditions or {}),
        "fitness": {k: named[k] for k in OBJECTIVES},
        "descriptors": {k: named[k] for k in DESCRIPTORS},
    }
    if library is not None:
        document["library"] = {"file": library.label, "digest": library.digest}
    if records is not None:
        document["per_trial"] = [r.as_dict() for r in records]
    return json.dumps(document)


def run(argv: Sequence[str] | None = None) -> str:
    """Parse ``argv``, evaluate, and return the JSON text; raise UsageError on bad input."""
    args = _parser().parse_args(argv)
    if not 1 <= args.trials <= MAX_TRIALS:
        raise UsageError(f"--trials must be in [1, {MAX_TRIALS}], got {args.trials}")
    if not 0 <= args.seed <= MAX_SEED:
        raise UsageError(f"--seed must be in [0, {MAX_SEED}], got {args.seed}")
    try:
        config, conditions = apply_conditions(args.condition, args.task.config(args.profile))
    except ConditionError as error:
        raise UsageError(f"--condition: {error}") from None
    library = library_option(args.library, UsageError)
    request: EvaluationRequest | SwarmRequest
    trees: Node | Network | list[Node | Network]  # every robot's tree, or each robot's own
    if args.swarm is not None:
        try:
            layout = load_layout(args.swarm, config.n_robots, library)
        except LayoutError as error:
            raise UsageError(f"--swarm: {error}") from None
        request = SwarmRequest(layout, seed=args.seed, trials=args.trials)
        trees = layout.parsed(library)
    else:
        text = args.tree
        if args.network is not None:
            try:
                text = controller_text(load_network(args.network))
            except NetworkError as error:
                raise UsageError(f"--network: {error}") from None
        request = EvaluationRequest(tree=text, seed=args.seed, trials=args.trials)
        try:
            trees = check_request(request, library=library)
        except ValueError as error:
            raise UsageError(str(error)) from None
    if args.engine == "reference":
        from swarm_sim.roads import reference_road  # (the controllers' modules: only for this engine)

        values, records = reference_road.evaluate(trees, args.seed, args.trials, config)
    else:
        result, records = BatchEvaluator(config, library=library).evaluate_trials([request])[0]
        if result.error is not None:
            raise UsageError(result.error)
        assert result.fitness is not None and result.descriptors is not None
        values = result.fitness + result.descriptors

    def canonical(tree: Node | Network) -> str:
        if library is None or isinstance(tree, Network):
            return controller_text(tree)
        return library.fold(tree)

    return evaluation_json(
        canonical(trees) if isinstance(trees, Node | Network) else [canonical(t) for t in trees],
        args.seed,
        args.trials,
        values,
        records if args.per_trial else None,
        args.profile,
        conditions,
        library,
        args.task,
    )


def evaluate_main(argv: Sequence[str] | None = None) -> int:
    """Console entry point of ``evaluate``."""
    try:
        text = run(argv)
    except UsageError as error:
        message = " ".join(str(error).split())
        print(f"evaluate: error: {message}", file=sys.stderr)
        return EXIT_USAGE
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(evaluate_main())
