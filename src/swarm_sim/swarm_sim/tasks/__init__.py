"""Tasks as data: a trial's world and its scoring declared once, as a ``TaskSpec`` value or a YAML file.

    from swarm_sim.tasks import resolve_task, task_to_yaml
    task = resolve_task("foraging")          # or resolve_task("my_task.yaml")
    config = task.config("paper")            # the world model's Config under a profile

The named tasks live in one registry (``register``, ``task_named``, ``task_names``); every command's
``--task`` takes a name or a file through ``add_task_option``. ``docs/tasks.md`` gives every key with its unit
and default, and how to add a task, a condition and an objective.
"""

from swarm_sim.tasks._arenas import UNSEEN_FIRST_ENTRY, arena_task
from swarm_sim.tasks._files import (
    read_task_file,
    task_from_mapping,
    task_from_yaml,
    task_to_mapping,
    task_to_yaml,
)
from swarm_sim.tasks._option import add_task_option, task_argument, task_label
from swarm_sim.tasks._registry import (
    AGGREGATION,
    DEFAULT_TASK,
    FORAGING,
    FORAGING_2026,
    PRIMITIVES,
    register,
    registered_name,
    resolve_task,
    task_from_record,
    task_named,
    task_names,
    task_to_record,
    unseen_twin,
)
from swarm_sim.tasks._spec import (
    TASK_CONFIG_FIELDS,
    Arena,
    Communication,
    Motors,
    Nodes,
    Region,
    Robots,
    Scoring,
    TaskError,
    TaskSpec,
    Trials,
    world_parameters,
)

__all__ = [
    "AGGREGATION",
    "DEFAULT_TASK",
    "FORAGING",
    "FORAGING_2026",
    "PRIMITIVES",
    "TASK_CONFIG_FIELDS",
    "UNSEEN_FIRST_ENTRY",
    "Arena",
    "Communication",
    "Motors",
    "Nodes",
    "Region",
    "Robots",
    "Scoring",
    "TaskError",
    "TaskSpec",
    "Trials",
    "add_task_option",
    "arena_task",
    "read_task_file",
    "register",
    "registered_name",
    "resolve_task",
    "task_argument",
    "task_from_mapping",
    "task_from_record",
    "task_from_yaml",
    "task_label",
    "task_named",
    "task_names",
    "task_to_mapping",
    "task_to_record",
    "task_to_yaml",
    "unseen_twin",
    "world_parameters",
]
