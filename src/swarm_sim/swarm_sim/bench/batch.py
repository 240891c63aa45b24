"""``ws/run swarm_sim bench``: evaluations per second of both roads, and (``--parity N``) their agreement.

    bench [--trees 200] [--reference-trees 4] [--trials 10] [--seed 0] [--parity N] [--threads K]
          [--profile paper|clean] [--task primitives|foraging]

Trees are ``bt_controller.language.random_trees.random_trees(seed, n)`` (11 to 60 nodes; with ``--task
foraging`` some inner nodes are success decorators, and got_food is among the conditions of both tasks'
trees). ``--task foraging`` times 100 s trials (800 steps each; ``swarm_sim.tasks``). The batch evaluator is
timed after a warm-up batch (compilation excluded) on one batch of ``--trees`` requests, in wall-clock time
and in CPU time of this process (the fairer figure on a shared machine); the reference road on the first
``--reference-trees`` of them. ``--parity N`` then evaluates N random trees by both roads and counts
disagreements (any bit of any of the six values, or of any end pose); the exit status is 1 if there is one.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

import numba

from bt_controller.draws import MAX_SEED
from bt_controller.language import parse, random_trees
from bt_controller.model_settings import PROFILES
from bt_controller.validate import check_options
from swarm_sim.evaluation import MAX_TRIALS, BatchEvaluator, EvaluationRequest, check_request, most_threads
from swarm_sim.model import DEFAULT, Config
from swarm_sim.roads import reference_road
from swarm_sim.tasks import add_task_option


def _batch_rate(evaluator: BatchEvaluator, requests: list[EvaluationRequest]) -> tuple[float, float, float]:
    """(evaluations per wall second, wall seconds, evaluations per CPU second of this process)."""
    evaluator.evaluate(requests[:2])  # compile or load the kernels
    start, cpu_start = time.perf_counter(), time.process_time()
    results = evaluator.evaluate(requests)
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    bad = [r.error for r in results if r.error]
    if bad:
        raise RuntimeError(f"benchmark trees failed: {bad[0]}")
    return len(requests) / elapsed, elapsed, len(requests) / cpu


def _reference_rate(requests: list[EvaluationRequest], config: Config) -> tuple[float, float]:
    trees = [check_request(r) for r in requests]
    reference_road.evaluate(trees[0], 0, 1, config)  # warm the compiled world functions
    start = time.perf_counter()
    for tree, request in zip(trees, requests, strict=True):
        reference_road.evaluate(tree, request.seed, request.trials, config)
    elapsed = time.perf_counter() - start
    return len(requests) / elapsed, elapsed


def parity(n_trees: int, seed: int, trials: int, config: Config = DEFAULT) -> int:
    """Evaluate ``n_trees`` random trees by both roads; print and return the number of disagreements."""
    evaluator = BatchEvaluator(config)
    texts = random_trees(seed + 1, n_trees, p_success=0.1)
    requests = [EvaluationRequest(t, seed + k, trials) for k, t in enumerate(texts)]
    batch = evaluator.evaluate_trials(requests)
    mismatches = 0
    for request, (result, records) in zip(requests, batch, strict=True):
        values, ref_records = reference_road.evaluate(
            check_request(request), request.seed, request.trials, config
        )
        assert result.fitness is not None and result.descriptors is not None
        same = values == result.fitness + result.descriptors and all(
            a.values == b.values and (a.end_poses == b.end_poses).all()
            for a, b in zip(records, ref_records, strict=True)
        )
        if not same:
            mismatches += 1
            print(f"parity: MISMATCH seed {request.seed} tree {request.tree}", file=sys.stderr)
    print(
        f"parity: {n_trees - mismatches}/{n_trees} random trees identical on both roads ({trials} trials, "
        f"profile {config.profile})"
    )
    return mismatches


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point of ``bench``."""
    parser = argparse.ArgumentParser(prog="bench", description=__doc__.split("\n")[0])
    parser.add_argument("--trees", type=int, default=200, help="requests in the timed batch")
    parser.add_argument(
        "--reference-trees", type=int, default=4, help="requests timed on the reference road (0: none)"
    )
    parser.add_argument("--trials", type=int, default=10, help="trials per evaluation")
    parser.add_argument("--seed", type=int, default=0, help="seed of the tree set and of the requests")
    parser.add_argument("--parity", type=int, default=0, metavar="N", help="also compare roads on N trees")
    parser.add_argument("--threads", type=int, default=1, help="numba threads (default 1)")
    parser.add_argument("--profile", choices=PROFILES, default=DEFAULT.profile, help="the model's profile")
    add_task_option(parser)
    args = parser.parse_args(argv)
    counted = max(args.trees, args.reference_trees, args.parity + 1)  # seeds seed .. seed + counted - 1
    bounds = {
        "trees": (1, None),
        "reference_trees": (0, None),  # the first of the batch's trees, as many as there are
        "trials": (1, MAX_TRIALS),
        "seed": (0, MAX_SEED - counted),
        "parity": (0, None),
        "threads": (1, most_threads()),
    }
    try:
        check_options(args, bounds)
    except ValueError as error:
        parser.error(str(error))
    config = args.task.config(args.profile)
    numba.set_num_threads(args.threads)

    texts = random_trees(
        args.seed, args.trees, p_success=0.1 if "got_food" in args.task.nodes.conditions else 0.0
    )
    requests = [EvaluationRequest(t, args.seed + k, args.trials) for k, t in enumerate(texts)]
    sizes = [parse(t).size for t in texts]
    print(
        f"trees: {len(texts)} random, {min(sizes)}-{max(sizes)} nodes (mean {sum(sizes) / len(sizes):.1f}); "
        f"{args.trials} trials of {config.trial_steps} steps per evaluation; profile {config.profile}, "
        f"task {args.task.name}"
    )
    batch_rate, batch_time, cpu_rate = _batch_rate(BatchEvaluator(config, threads=args.threads), requests)
    print(
        f"batch:     {batch_rate:8.1f} evaluations/s ({len(requests)} in {batch_time:.2f} s, {args.threads} "
        f"thread(s); {cpu_rate:.1f} per CPU-second)"
    )
    if args.reference_trees:  # 0: the batch road alone (the reference road takes seconds a tree)
        ref_requests = requests[: args.reference_trees]
        ref_rate, ref_time = _reference_rate(ref_requests, config)
        print(f"reference: {ref_rate:8.2f} evaluations/s ({len(ref_requests)} in {ref_time:.2f} s)")
        print(f"ratio:     {batch_rate / ref_rate:8.0f}x")
    if args.parity:
        return 1 if parity(args.parity, args.seed, args.trials, config) else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
