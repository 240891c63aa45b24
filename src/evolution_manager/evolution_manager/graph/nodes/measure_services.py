"""``measure-services``: what evaluating over ROS 2 services costs, against the in-process batch evaluator.

    ws/run evolution_manager measure-services [--evaluations 2000] [--rounds 3] [--json FILE]

It first runs MAP-Elites for go-to-food in-process to get a real run's batches (its requests: trees, seeds,
10 trials), then evaluates those same batches, round after round so that a change in the machine's load
falls on every configuration alike, with:

- the in-process ``BatchEvaluator`` (one thread, and two threads);
- a manager-style loop (``ServiceEvaluator``, chunks of at most ``--chunk`` requests) over one evaluator node,
  and over two evaluator nodes (separate processes started here, in a domain of their own).

Every road first evaluates every batch once (compiling kernels, remembering flattened trees); then the
rounds are timed. It reports evaluations per second (wall clock; median over rounds) and CPU milliseconds per
evaluation (the measuring process plus the evaluator processes, from ``/proc``: the fair figure on a shared
machine), and the services' overhead: for one node, the extra wall time against the in-process evaluator (the
median over rounds of each round's ratio), and the extra CPU per evaluation. The issue's target: under 10 %.
Results must be equal bit for bit on every road (checked). This is a measurement, never a test.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from evolution_manager.evolution.run_config import RunConfig, evaluation_seed
from evolution_manager.graph.dispatch import Timeouts
from evolution_manager.graph.service_evaluator import ServiceEvaluator, ServiceSettings
from evolution_manager.graph.startup import Graph
from swarm_ros.isolation import reserved_domain
from swarm_ros.safe_paths import check_output, describe, replace_file
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest

_TICKS = os.sysconf("SC_CLK_TCK")


def process_cpu(pid: int) -> float:
    """CPU seconds (user + system) used so far by process ``pid``."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / _TICKS


def run_batches(evaluations: int, seed: int, trials: int) -> list[list[EvaluationRequest]]:
    """The batches of requests of an in-process MAP-Elites run (go-to-food)."""
    algorithm = RunConfig.make("qd", "food", evaluations, seed, trials).make_algorithm()
    evaluator = BatchEvaluator()
    batches = []
    done = 0
    while not algorithm.done:
        trees = algorithm.ask()
        batch = [
            EvaluationRequest(tree, evaluation_seed(seed, done + i), trials) for i, tree in enumerate(trees)
        ]
        algorithm.tell(evaluator.evaluate(batch))
        batches.append(batch)
        done += len(batch)
    return batches


def timed(evaluate: Callable, batches: Sequence, pids: Sequence[int]) -> tuple[float, float, list]:
    """Wall seconds, CPU seconds (this process and ``pids``) and the results of evaluating ``batches``."""
    cpu0 = time.process_time() + sum(process_cpu(p) for p in pids)
    wall0 = time.perf_counter()
    results = [evaluate(batch) for batch in batches]
    wall = time.perf_counter() - wall0
    cpu = time.process_time() + sum(process_cpu(p) for p in pids) - cpu0
    return wall, cpu, results


def measure(args: argparse.Namespace) -> dict:
    print(f"getting the batches of a {args.evaluations}-evaluation MAP-Elites run ...", flush=True)
    batches = run_batches(args.evaluations, args.seed, args.trials)
    n = sum(len(b) for b in batches)
    sizes = sorted({len(b) for b in batches})
    roads: dict[str, Callable] = {
        "in-process, 1 thread": BatchEvaluator().evaluate,
        "in-process, 2 threads": BatchEvaluator(threads=2).evaluate,
    }
    pids: dict[str, list[int]] = {name: [] for name in roads}
    samples: dict[str, list[tuple[float, float]]] = {}
    with reserved_domain() as domain, Graph(domain) as graph:
        for i in (1, 2):
            graph.start(f"evaluator_{i}", "swarm_sim", "evaluator", node_name=f"measure_evaluator_{i}")
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        node = Node("measure_services", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        try:
            settings = ServiceSettings(max_chunk=args.chunk, timeouts=Timeouts(timeout=120.0))
            names = [f"/measure_evaluator_{i}/evaluate" for i in (1, 2)]
            for k in (1, 2):
                services = ServiceEvaluator(node, executor, settings, only=names[:k])
                if len(services.wait_for(k, 120.0)) < k:
                    raise RuntimeError("the evaluator nodes did not come up within 120 s")
                label = f"services, {k} evaluator node{'s' if k > 1 else ''}"
                roads[label] = services.evaluate
                pids[label] = [graph.processes[f"evaluator_{i}"].pid for i in range(1, k + 1)]
            # Warm up over every batch: the nodes compile their kernels and, like this process, remember
            # the flattened trees (parsing is a cost of every road alike, not of the services).
            print("warming up ...", flush=True)
            for evaluate in roads.values():
                for batch in batches:
                    evaluate(batch)
            reference = None
            order = list(roads)
            for r in range(args.rounds):
                for label in order[r % len(order) :] + order[: r % len(order)]:  # each round starts elsewhere
                    evaluate = roads[label]
                    wall, cpu, results = timed(evaluate, batches, pids[label])
                    if reference is None:
                        reference = results
                    if results != reference:
                        raise RuntimeError(f"{label} gave other results than the in-process evaluator")
                    samples.setdefault(label, []).append((wall, cpu))
                    print(f"round {r + 1}: {label}: {n / wall:.1f} evaluations/s", flush=True)
        finally:
            executor.shutdown()
            node.destroy_node()
            rclpy.shutdown(context=context)
    rows = {}
    for label, values in samples.items():
        wall = statistics.median(w for w, _ in values)
        cpu = statistics.median(c for _, c in values)
        rows[label] = {"evaluations_per_second": n / wall, "cpu_ms_per_evaluation": 1000 * cpu / n}
    base = rows["in-process, 1 thread"]
    one = rows["services, 1 evaluator node"]
    two = rows["services, 2 evaluator nodes"]

    def paired(label: str) -> float:
        """The median over rounds of (service wall time / in-process wall time) - 1: each round's load
        falls on both alike."""
        ratios = [s[0] / b[0] for s, b in zip(samples[label], samples["in-process, 1 thread"], strict=True)]
        return statistics.median(ratios) - 1

    return {
        "evaluations": n,
        "batches": len(batches),
        "batch_sizes": sizes,
        "trials": args.trials,
        "chunk": args.chunk,
        "rounds": args.rounds,
        "cpus": os.cpu_count(),
        "load_average": os.getloadavg(),
        "results": rows,
        "overhead_1_node_wall": paired("services, 1 evaluator node"),
        "overhead_1_node_cpu": one["cpu_ms_per_evaluation"] / base["cpu_ms_per_evaluation"] - 1,
        "overhead_2_nodes_cpu": two["cpu_ms_per_evaluation"] / base["cpu_ms_per_evaluation"] - 1,
        "speedup_2_nodes": two["evaluations_per_second"] / base["evaluations_per_second"],
    }


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point of ``measure-services``."""
    parser = argparse.ArgumentParser(prog="measure-services", description=__doc__.split("\n")[0])
    parser.add_argument("--evaluations", type=int, default=2000, help="size of the run measured")
    parser.add_argument("--trials", type=int, default=10, help="trials per evaluation (default 10)")
    parser.add_argument("--chunk", type=int, default=50, help="most requests per service call (default 50)")
    parser.add_argument("--rounds", type=int, default=3, help="rounds over every configuration (default 3)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", type=Path, help="also write the measurements to this file (new)")
    parser.add_argument("--force", action="store_true", help="overwrite a --json file that exists")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    try:  # refused before the graph starts: a link, a folder, a file there (unless --force)
        if args.json is not None:
            check_output(args.json, args.force, "--json")
    except OSError as error:
        print(f"measure-services: error: {describe(args.json, error)}", file=sys.stderr)
        return 2
    report = measure(args)
    print(
        f"\n{report['evaluations']} evaluations ({report['trials']} trials each) in {report['batches']} "
        f"batches of {report['batch_sizes']}; chunks of at most {report['chunk']}; median of "
        f"{report['rounds']} rounds; {report['cpus']} CPUs, load average {report['load_average'][0]:.1f}\n"
    )
    print("| road | evaluations/s | CPU ms/evaluation |")
    print("|---|---|---|")
    for label, row in report["results"].items():
        print(f"| {label} | {row['evaluations_per_second']:.1f} | {row['cpu_ms_per_evaluation']:.3f} |")
    print(
        f"\nservice overhead, 1 node: {100 * report['overhead_1_node_wall']:.1f} % wall time (median of "
        "paired rounds), "
        f"{100 * report['overhead_1_node_cpu']:.1f} % CPU per evaluation; 2 nodes: "
        f"{100 * report['overhead_2_nodes_cpu']:.1f} % CPU per evaluation, "
        f"{report['speedup_2_nodes']:.2f}x the in-process 1-thread throughput"
    )
    if args.json:
        text = json.dumps(report, indent=1) + "\n"
        try:
            replace_file(args.json, lambda temporary: temporary.write_text(text))
        except OSError as error:
            print(f"measure-services: error: {describe(args.json, error)}", file=sys.stderr)
            return 74
    return 0


if __name__ == "__main__":
    sys.exit(main())
