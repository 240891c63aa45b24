"""``ws/run swarm_sim task list | show NAME|FILE | check FILE... | arena LAYOUT``: the registered tasks, a
task as the YAML file that reproduces it, a check of task files (one line per file; exit status 2 for a bad
one), and a task on the regions of one of the authors' 2026 arena layouts (``arena_task``)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from swarm_sim.tasks._arenas import arena_task
from swarm_sim.tasks._files import read_task_file, task_to_yaml
from swarm_sim.tasks._registry import resolve_task, task_named, task_names
from swarm_sim.tasks._spec import TaskError

EXIT_BAD = 2


def carries_option(text: str) -> tuple[tuple[str, ...], ...]:
    """``--carries``: groups separated by ``;``, a group's food kinds by ``,``, ``-`` for a group that carries
    nothing (``food,food2;-;food3``); the names are the task's to check."""
    groups = [group.strip() for group in text.split(";")]
    if not text.strip() or any(not group for group in groups):
        raise argparse.ArgumentTypeError(
            f"expected groups separated by ';', each of food kinds separated by ',' or '-' for none, "
            f"got {text!r}"
        )
    return tuple(() if group == "-" else tuple(kind.strip() for kind in group.split(",")) for group in groups)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="task", description="Tasks as data (docs/tasks.md): list, show and check them."
    )
    verbs = parser.add_subparsers(dest="verb", required=True, metavar="list|show|check|arena")
    verbs.add_parser("list", help="the registered tasks, one line each")
    show = verbs.add_parser("show", help="a task as YAML that reproduces it (save it and edit it)")
    show.add_argument("task", metavar="NAME|FILE")
    check = verbs.add_parser("check", help="check task files: one line each, exit status 2 for a bad one")
    check.add_argument("files", nargs="+", metavar="FILE")
    arena = verbs.add_parser(
        "arena", help="a task on the regions of the authors' 2026 arena LAYOUT (1-9), as YAML"
    )
    arena.add_argument("layout", type=int, metavar="LAYOUT")
    arena.add_argument("--task", default="foraging", metavar="NAME|FILE", help="the task (default: foraging)")
    arena.add_argument("--points", type=int, help="points per generated arena (layouts 7, 8)")
    arena.add_argument("--nest-radius", type=float, default=500.0, help="mm (default 500)")
    arena.add_argument("--food-radius", type=float, default=500.0, help="mm (default 500)")
    arena.add_argument(
        "--bias", type=int, help="layout 9: the preferred food kind, 0-based as theirs (their arenaBias: 0-2)"
    )
    arena.add_argument(
        "--other-food-weight",
        type=float,
        default=1.0,
        help="what another kind than the preferred one counts in foraging_biased (their penalty; default 1)",
    )
    arena.add_argument(
        "--balanced",
        action="store_true",
        help="add the objective foraging_balanced (the swarm's least delivered kind x the kinds)",
    )
    arena.add_argument(
        "--types",
        type=int,
        choices=(1, 2),
        default=1,
        help="2: the authors' two robot types, odd robots perceiving the nest and food swapped (default 1)",
    )
    arena.add_argument(
        "--carries",
        type=carries_option,
        default=(),
        metavar="GROUPS",
        help="robot groups that pick up only some food kinds (robots.carries): groups separated by ';', a "
        "group's kinds by ',', '-' for a group that carries nothing; e.g. 'food;food2;food3' (quote it) "
        "(default: every robot picks up every kind)",
    )
    arena.add_argument(
        "--ticks", type=int, help="the trials' length in ticks, 2 a second (default: the task's)"
    )
    arena.add_argument("--formation", help="the start formation (default: the task's)")
    arena.add_argument(
        "--first-entry",
        type=int,
        default=0,
        help="layouts 6-9: trial k takes generated arena FIRST_ENTRY + k (default 0, the authors'; 5: the "
        "arenas no run evolves on)",
    )
    args = parser.parse_args(argv)
    try:
        if args.verb == "list":
            for name in task_names():
                task = task_named(name)
                two = task.robots.types == 2
                types = ", two robot types (odd robots: nest and food swapped)" if two else ""
                if task.robots.carries:
                    types += f", {len(task.robots.carries)} robot groups carrying only some food kinds"
                print(
                    f"{name}: {task.trial_seconds:g} s trials, {task.robots.count} robots{types}, objectives "
                    f"{', '.join(task.objectives) or 'none'}"
                )
            return 0
        if args.verb == "show":
            sys.stdout.write(task_to_yaml(resolve_task(args.task)))
            return 0
        if args.verb == "arena":
            task = arena_task(
                resolve_task(args.task),
                args.layout,
                nest_radius=args.nest_radius,
                food_radius=args.food_radius,
                points=args.points,
                bias=args.bias,
                other_food_weight=args.other_food_weight,
                balanced=args.balanced,
                types=args.types,
                carries=args.carries,
                ticks=args.ticks,
                formation=args.formation,
                first_entry=args.first_entry,
            )
            sys.stdout.write(task_to_yaml(task))
            return 0
        bad = 0
        for path in args.files:
            try:
                task = read_task_file(Path(path))
            except TaskError as error:
                print(f"task: {error}", file=sys.stderr)
                bad += 1
                continue
            print(f"{path}: task {task.name!r}, ok")
        return EXIT_BAD if bad else 0
    except TaskError as error:
        print(f"task: {error}", file=sys.stderr)
        return EXIT_BAD


if __name__ == "__main__":
    sys.exit(main())
