"""``ws/run swarm_sim record-bench``: how long recording one trial for an animation takes, on both roads.

    record-bench [--trees 300] [--trial 0] [--seed 0] [--reference-trees 3] [--profile paper|clean]

Prints the first call (compiling or loading the kernels), then, for ``--trees`` different random trees
(``bt_controller.language.random_trees``; the repertoire explorer animates one trial of the best tree of each
filled bin, up to 512), the total and per-trial time of ``record_trial``, in wall-clock time and CPU time of
this process (the fairer figure on a shared machine); then ``record_trial_reference`` on the first
``--reference-trees`` of them (after a warm-up), and the ratio.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from bt_controller.draws import MAX_SEED
from bt_controller.language import random_trees
from bt_controller.model_settings import PROFILES
from bt_controller.validate import check_options
from swarm_sim.evaluation import MAX_TRIALS
from swarm_sim.model import DEFAULT, default_config
from swarm_sim.roads import record_trial, record_trial_reference, warm_up


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point of ``record-bench``."""
    parser = argparse.ArgumentParser(prog="record-bench", description=__doc__.split("\n")[0])
    parser.add_argument("--trees", type=int, default=300, help="trees recorded on the compiled road")
    parser.add_argument("--trial", type=int, default=0, help="the trial recorded (default 0)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the tree set and of the trials")
    parser.add_argument("--reference-trees", type=int, default=3, help="trees recorded on the reference road")
    parser.add_argument("--profile", choices=PROFILES, default=DEFAULT.profile, help="the model's profile")
    args = parser.parse_args(argv)
    counted = max(args.trees, args.reference_trees)  # seeds seed .. seed + counted - 1
    bounds = {
        "trees": (1, None),
        "reference_trees": (0, None),
        "trial": (0, MAX_TRIALS - 1),
        "seed": (0, MAX_SEED - counted),
    }
    try:
        check_options(args, bounds)
    except ValueError as error:
        parser.error(str(error))
    config = default_config(args.profile)
    texts = random_trees(args.seed, max(args.trees, args.reference_trees))
    print(f"trial {args.trial} of {args.trees} random trees; profile {config.profile}")

    start = time.perf_counter()
    record_trial(texts[0], args.seed, args.trial, config)
    print(f"first call:  {time.perf_counter() - start:7.3f} s (compiling or loading the kernels)")

    start, cpu_start = time.perf_counter(), time.process_time()
    for k, text in enumerate(texts[: args.trees]):
        record_trial(text, args.seed + k, args.trial, config)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    per_trial = wall / args.trees
    print(
        f"compiled:    {wall:7.3f} s for {args.trees} trees: {1000 * per_trial:.2f} ms a trial "
        f"({1000 * cpu / args.trees:.2f} ms CPU)"
    )
    if args.reference_trees:
        warm_up(config)  # compile or load the world functions the reference road calls
        start = time.perf_counter()
        for k, text in enumerate(texts[: args.reference_trees]):
            record_trial_reference(text, args.seed + k, args.trial, config)
        reference = (time.perf_counter() - start) / args.reference_trees
        print(f"reference:   {1000 * reference:7.1f} ms a trial ({args.reference_trees} trees)")
        print(f"ratio:       {reference / per_trial:7.0f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
