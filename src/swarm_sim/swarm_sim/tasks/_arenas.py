"""The authors' 2026 arena layouts as tasks: ``arena_task`` turns a layout's entries
(``swarm_sim.model.arenas``) into the regions of a task, so that a layout can be shown as a task file, edited
and run.

The regions (with the three food kinds of layouts 5, 6 and 9), the random start area ([-1500, 1500] mm), the
numbered food conditions, the bias and penalty of layout 9, and the robots' perception under ``paper``
(``authors_code`` 2026: estimates afresh at every trial, no robot seen when nobody is heard) come from the
2026 code. Their two runs per evaluation (gaps 500 and 700 mm) are this model's two blocks of trials, and
trial k of a block takes the layout's entry k, as theirs does.
"""

from __future__ import annotations

from dataclasses import replace

from bt_controller.language import MULTIFOOD_CONDITIONS
from bt_controller.model_settings import CODE_2026
from swarm_sim.errors import ConfigError
from swarm_sim.model import FOOD_KINDS, GENERATED_LAYOUTS, arena_entries
from swarm_sim.model.regions import ArenaEntry
from swarm_sim.tasks._spec import Arena, Nodes, Region, Scoring, TaskError, TaskSpec

START_HALF_2026 = 1500.0
"""The 2026 code's random start area: uniform in [-1.5, 1.5]^2 m (``bt_loop_functions.cpp:1156``)."""

GAPS = (500.0, 700.0)
"""Their two runs' gaps (``arena_params``), one block of trials each."""

UNSEEN_FIRST_ENTRY = 5
"""The first of the generated arenas that neither the authors' runs nor ours evolve on: a block has five
trials, which take entries 0 to 4 of the ten."""


def arena_task(
    base: TaskSpec,
    layout: int,
    *,
    nest_radius: float = 500.0,
    food_radius: float = 500.0,
    points: int | None = None,
    bias: int | None = None,
    other_food_weight: float = 1.0,
    balanced: bool = False,
    types: int = 1,
    carries: tuple[tuple[str, ...], ...] = (),
    ticks: int | None = None,
    formation: str | None = None,
    first_entry: int = 0,
    name: str | None = None,
) -> TaskSpec:
    """``base`` (a foraging task, say) on the regions of the authors' arena ``layout``, named ``name`` (by
    default ``<base>-arena<layout>``), with the 2026 random start area. Layout 9 needs ``bias``, the preferred
    food kind 0-based as theirs (``arenaBias``), which the task's ``foraging_biased`` objective prefers with
    ``other_food_weight`` for the others (their ``penalty``). A layout with several food kinds gets their
    node set (``vocabulary.MULTIFOOD_CONDITIONS``) and the per-kind objectives. ``balanced`` adds the
    objective ``foraging_balanced`` (the swarm's least delivered kind, this project's: issue 36), which only a
    swarm delivering every kind alike maximises. ``types`` 2 gives the
    authors' two robot types (``Robots.types``: odd robots perceive the nest and food kind 1 swapped, as in
    their ``generic`` projects, where it matters in layouts 7 and 8); ``carries`` the food kinds each robot
    group can pick up (``Robots.carries``; empty: every kind); ``ticks`` the trials' length (None:
    ``base``'s); ``formation`` the start formation (None: ``base``'s). ``first_entry``: trial k of a block
    takes the generated layout's entry ``first_entry + k`` (wrapping round its ten); 0 is the authors' choice,
    and since a block has five trials their runs never see entries 5 to 9, which :data:`UNSEEN_FIRST_ENTRY`
    gives (arenas none of their runs or ours evolved on). ``TaskError`` in one line for a bad setting."""
    try:
        rows = [arena_entries(layout, nest_radius=nest_radius, food_radius=food_radius, gap=g, points=points,
                              bias=bias)
                for g in GAPS]  # fmt: skip
    except ConfigError as error:
        raise TaskError(f"arena {layout}: {error}") from None
    kinds = sorted(
        {piece.kind for row in rows for entry in row for piece in entry} - {"nest"}, key=FOOD_KINDS.index
    )
    if first_entry and layout not in GENERATED_LAYOUTS:
        raise TaskError(
            f"arena {layout}: first_entry applies only to the generated layouts 6-9 (ten arenas each), got "
            f"{first_entry!r}"
        )
    if (
        isinstance(first_entry, bool)
        or not isinstance(first_entry, int)
        or not 0 <= first_entry < len(rows[0])
    ):
        raise TaskError(f"arena {layout}: first_entry must be 0 to {len(rows[0]) - 1}, got {first_entry!r}")
    per_block = base.trials.chain_trials
    entries: list[ArenaEntry] = []
    for row in rows if rows[0] != rows[1] else rows[:1]:  # generated layouts do not change with the gap
        entries += [row[(first_entry + k) % len(row)] for k in range(per_block if len(row) > 1 else 1)]
    trial_entries = per_block if len(rows[0]) > 1 else 1
    regions = tuple(
        Region(
            entries[0][m].kind,
            entries[0][m].shape,
            _once(tuple(entry[m].radius for entry in entries)),
            _once(tuple((entry[m].x, entry[m].y) for entry in entries)),
        )
        for m in range(len(entries[0]))
    )
    several = len(kinds) > 1
    preferred = 0 if bias is None else bias + 1
    objectives = base.objectives
    if several:
        objectives = (
            *objectives,
            *(f"foraging{k}" for k in range(1, len(kinds) + 1) if f"foraging{k}" not in objectives),
        )
    if preferred and "foraging_biased" not in objectives:
        objectives = (*objectives, "foraging_biased")
    if balanced and "foraging_balanced" not in objectives:
        objectives = (*objectives, "foraging_balanced")
    what = f"{len(kinds)} food kinds" if several else "one food kind"
    told = f", food kind {preferred} preferred (other kinds count {other_food_weight:g})" if preferred else ""
    if balanced:
        told += ", scored by its least delivered kind (foraging_balanced)"
    if types == 2:
        told += ", two robot types (odd robots perceive the nest and food swapped)"
    if carries:
        groups = " / ".join("+".join(group) or "nothing" for group in carries)
        told += f", {len(carries)} robot groups, each picking up only its food kinds ({groups})"
    robots = replace(
        base.robots,
        start_half_size=START_HALF_2026,
        types=types,
        carries=carries,
        formation=base.robots.formation if formation is None else formation,
    )
    if robots.formation != "random":
        told += f", {robots.formation} start"
    if first_entry:
        told += f", trial k on its arena {first_entry} + k"
    trials = base.trials if ticks is None else replace(base.trials, ticks=ticks)
    if ticks is not None:
        told += f", trials of {ticks / 2:g} s"
    return replace(
        base,
        name=name or f"{base.name}-arena{layout}",
        description=f"{base.name} on the regions of the authors' 2026 arena {layout}, {what}{told}, as "
        "their 2026 code runs it (its start area and its robots' perception).",
        authors_code=CODE_2026,
        arena=Arena(half_size=base.arena.half_size, trial_entries=trial_entries),
        regions=regions,
        trials=trials,
        robots=robots,
        objectives=objectives,
        scoring=Scoring(preferred_food=preferred, other_food_weight=other_food_weight),
        nodes=Nodes(MULTIFOOD_CONDITIONS, base.nodes.actions) if several else base.nodes,
    )


def _once(values: tuple) -> tuple:
    """``values``, or its one value when every entry has the same (a task file gives it once)."""
    return values[:1] if len(set(values)) == 1 else values
