"""The one ``--task`` option every command declares: a registered name or a task file."""

from __future__ import annotations

import argparse

from swarm_sim.tasks._registry import DEFAULT_TASK, registered_name, resolve_task, task_names
from swarm_sim.tasks._spec import TaskError, TaskSpec


def task_argument(text: str) -> TaskSpec:
    """argparse's type for ``--task``: the task of a registered name or a task file, or argparse's error
    with the one line that says why not."""
    try:
        return resolve_task(text)
    except TaskError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_task_option(
    parser: argparse.ArgumentParser, *, default: str | None = DEFAULT_TASK, what: str = ""
) -> None:
    """Declare ``--task NAME|FILE`` on ``parser``; ``default`` None leaves it None when not given (a command
    that reads the task from elsewhere, such as a run being resumed); ``what`` adds to the help."""
    names = ", ".join(task_names())
    default_text = f" (default {default})" if default is not None else ""
    parser.add_argument(
        "--task",
        type=task_argument,
        default=None if default is None else resolve_task(default),
        metavar="NAME|FILE",
        help=f"the task: a registered one ({names}; `ws/run swarm_sim task list`) or a task file (YAML, "
        f"docs/tasks.md){default_text}{what}",
    )


def task_label(task: TaskSpec) -> str:
    """How messages name a task: its name, marked when it is not exactly the registered task of that name."""
    return task.name if registered_name(task) is not None else f"{task.name} (from a task file)"
