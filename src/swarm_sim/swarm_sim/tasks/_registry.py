"""The named tasks: one registry, ``register`` to add one, ``task_named`` and ``resolve_task`` to find one.

``primitives`` and ``foraging`` are the two papers' tasks; a variant of a task is one registration
(``dataclasses.replace`` of a registered spec), not new code.
"""

from __future__ import annotations

import difflib
from dataclasses import replace
from pathlib import Path
from typing import Any

from bt_controller.language import CONDITIONS_2023, CONDITIONS_2024
from bt_controller.model_settings import CODE_2026
from swarm_sim.model import GENERATED_LAYOUTS, PAPER_OBJECTIVES
from swarm_sim.tasks._arenas import UNSEEN_FIRST_ENTRY, arena_task
from swarm_sim.tasks._files import read_task_file, task_from_mapping, task_to_mapping
from swarm_sim.tasks._spec import Nodes, TaskError, TaskSpec, Trials

PRIMITIVES = TaskSpec(
    name="primitives",
    description="The 2023 paper's trials of 20 s, in which the six primitives are evolved: nine footbots, "
    "a nest disc at the centre and food beyond 1000 mm, then 1200 mm, by blocks of five trials.",
    objectives=PAPER_OBJECTIVES,
    nodes=Nodes(conditions=CONDITIONS_2023),
)
"""The 2023 experiment's task: its objectives, its node set (table 3's conditions), 40-tick trials."""

FORAGING = replace(
    PRIMITIVES,
    name="foraging",
    description="The 2024 follow-up's foraging trials of 100 s in the same arena: robots carry food from the "
    "food region to the nest; got_food joins the conditions.",
    trials=Trials(ticks=200),
    objectives=("foraging",),
    nodes=Nodes(conditions=CONDITIONS_2024),
)
"""The 2024 foraging task (``footbot_bt.cpp:493,538,546,551`` at a73e4af: 200 ticks, 800 steps)."""

AGGREGATION = replace(
    PRIMITIVES,
    name="aggregation",
    description="A task of this project's own, which neither paper has: nine footbots scattered over the "
    "arena (start square of 2000 mm half-side) gather into one group in trials of 60 s, sensing only each "
    "other (robot_left, robot_right); scored by the fall of each robot's true mean distance from the others. "
    "The nest and food of the 2023 arena stay on the ground, unread.",
    trials=Trials(ticks=120),
    robots=replace(PRIMITIVES.robots, start_half_size=2000.0),
    objectives=("aggregation",),
    nodes=Nodes(conditions=("robot_left", "robot_right")),
)
"""Aggregation, this project's own task (``docs/tasks.md`` works through it)."""

_REGISTRY: dict[str, TaskSpec] = {}

DEFAULT_TASK = "primitives"


def register(task: TaskSpec) -> TaskSpec:
    """Add ``task`` to the registry under its name (refused when the name is taken by another spec)."""
    known = _REGISTRY.get(task.name)
    if known is not None and known != task:
        raise TaskError(f"a task named {task.name!r} is already registered")
    _REGISTRY[task.name] = task
    return task


register(PRIMITIVES)
register(FORAGING)
register(AGGREGATION)
FORAGING_2026 = register(
    replace(
        FORAGING,
        name="foraging-2026",
        description="foraging as the authors' 2026 code runs it (commit 1cd2358: estimates afresh at every "
        "trial, no robot seen when nobody is heard), in the 2024 arena with the 2024 start area.",
        authors_code=CODE_2026,
    )
)
"""The 2024 foraging task in the authors' 2026 code: their single-food setting closest to the 2024 paper's
(arena 1, the [-1, 1] m start area), which agrees with the 2024 code within noise in their simulator."""

CARRIERS_TICKS = 600
"""``multifood-arena6-carriers``' trials: 300 s."""

ARENA9_OTHER_FOOD_WEIGHT = 0.5
"""The penalty of the authors' arena-9 runs and of their public reference data (``argos_stats_multifood``)."""

# The authors' 2026 arenas as tasks (``arena_task``): ``multifood-arena1`` to ``-arena8``, and arena 9 with
# each food kind preferred (``multifood-arena9-kind2``: their 0-based ``arenaBias`` 1, the setting of their
# public reference data beside ``multifood-arena6``); and the authors' two robot types (their ``generic``
# projects) in the two layouts where a type changes what a robot perceives, 7 and 8 (``footbot_bt.cpp:242-254,
# 269`` at 1cd2358), each robot starting around its own food kind 1 (the ``localised`` formation: even robots
# at the food point, odd ones at the nest point). ``multifood-arena6-balanced`` is arena 6 scored by
# ``foraging_balanced`` (this project's, issue 36: meant as a task where a division of labour could pay), and
# ``multifood-arena6-carriers`` the same with three robot groups that each pick up only one kind
# (``Robots.carries``: robots 0, 3, 6 food, 1, 4, 7 food2, 2, 5, 8 food3) in trials of 300 s (at 100 s
# deliveries are too rare to measure), where robots differ in what they can do, not only in what they sense.
_ARENA_TASKS: tuple[tuple[str, dict[str, Any]], ...] = (
    *((f"multifood-arena{layout}", {"layout": layout}) for layout in range(1, 9)),
    *(
        (
            f"multifood-arena9-kind{kind}",
            {"layout": 9, "bias": kind - 1, "other_food_weight": ARENA9_OTHER_FOOD_WEIGHT},
        )
        for kind in (1, 2, 3)
    ),
    *(
        (f"multifood-arena{layout}-types", {"layout": layout, "types": 2, "formation": "localised"})
        for layout in (7, 8)
    ),
    ("multifood-arena6-balanced", {"layout": 6, "balanced": True}),
    (
        "multifood-arena6-carriers",
        {
            "layout": 6,
            "balanced": True,
            "ticks": CARRIERS_TICKS,
            "carries": (("food",), ("food2",), ("food3",)),
        },
    ),
)
for _name, _settings in _ARENA_TASKS:
    register(arena_task(FORAGING, name=_name, **_settings))

# Each generated layout's task again on the arenas no run evolves on (``UNSEEN_FIRST_ENTRY``: entries 5 to 9
# of the ten), named ``<task>-unseen``: where a controller evolved on a task is tested on arenas it never met.
UNSEEN_SUFFIX = "-unseen"
for _name, _settings in _ARENA_TASKS:
    if _settings["layout"] in GENERATED_LAYOUTS:
        register(
            arena_task(FORAGING, first_entry=UNSEEN_FIRST_ENTRY, name=_name + UNSEEN_SUFFIX, **_settings)
        )


def unseen_twin(name: str) -> TaskSpec:
    """The registered task ``name`` on the arenas no run evolves on (``<name>-unseen``); ``TaskError`` in one
    line for a task that has none (only the generated layouts 6-9 have more arenas than a block's trials)."""
    twin = name + UNSEEN_SUFFIX
    if twin not in _REGISTRY:
        with_twins = [n for n in _REGISTRY if n + UNSEEN_SUFFIX in _REGISTRY]
        raise TaskError(f"task {name!r} has no unseen arenas; the tasks that have: {', '.join(with_twins)}")
    return _REGISTRY[twin]


def task_names() -> tuple[str, ...]:
    """The registered tasks' names, in registration order."""
    return tuple(_REGISTRY)


def task_named(name: str) -> TaskSpec:
    """The registered task ``name``; ``TaskError`` naming the registered ones (and the nearest) otherwise."""
    if name in _REGISTRY:
        return _REGISTRY[name]
    close = difflib.get_close_matches(name, list(_REGISTRY), n=1)
    hint = f" (did you mean {close[0]}?)" if close else ""
    raise TaskError(f"task must be one of {', '.join(_REGISTRY)} or a task file (.yaml), got {name!r}{hint}")


def resolve_task(value: str | TaskSpec) -> TaskSpec:
    """A task from a registered name or the path of a task file (``.yaml``/``.yml``, or any file that exists);
    a ``TaskSpec`` is returned as it is."""
    if isinstance(value, TaskSpec):
        return value
    if value in _REGISTRY:
        return _REGISTRY[value]
    path = Path(value)
    if path.suffix in (".yaml", ".yml") or path.is_file():
        return read_task_file(path)
    return task_named(value)


def registered_name(task: TaskSpec) -> str | None:
    """The name under which exactly ``task`` is registered, or None (a task of its own, or an edited one)."""
    return task.name if _REGISTRY.get(task.name) == task else None


def task_to_record(task: TaskSpec) -> str | dict[str, Any]:
    """How a run's files (``config.json``) keep ``task``: the name of a registered task it equals exactly,
    else every key (a task of one's own, or an edited one), so that the file always says the whole world."""
    return registered_name(task) or task_to_mapping(task)


def task_from_record(value: object, where: str = "task") -> TaskSpec:
    """The task a run's file keeps (``task_to_record``); None (files of before tasks): ``primitives``."""
    if value is None:
        return task_named(DEFAULT_TASK)
    if isinstance(value, str):
        return task_named(value)
    return task_from_mapping(value, where)
