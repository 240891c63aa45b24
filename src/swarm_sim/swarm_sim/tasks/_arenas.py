"""The authors' 2026 arena layouts as tasks: ``arena_task`` turns a layout's entries
(``swarm_sim.model.arenas``) into the regions of a task, so that a layout can be shown as a task file, edited
and run.

Only the regions come from the 2026 code, with its random start area ([-1500, 1500] mm). The rest is this
project's model of the 2024 code (its perception, messages and trials; ``docs/model.md``), and only layouts
with one food kind (1-4, 7 and 8) run: the three food kinds of layouts 5, 6 and 9 come with issue 35's next
step. Their two runs per evaluation (gaps 500 and 700 mm) are this model's two blocks of trials, and trial k
of a block takes the layout's entry k, as theirs does.
"""

from __future__ import annotations

from dataclasses import replace

from swarm_sim.errors import ConfigError
from swarm_sim.model import FOOD_KINDS, REGION_KINDS, arena_entries
from swarm_sim.model.regions import ArenaEntry
from swarm_sim.tasks._spec import Arena, Region, TaskError, TaskSpec

START_HALF_2026 = 1500.0
"""The 2026 code's random start area: uniform in [-1.5, 1.5]^2 m (``bt_loop_functions.cpp:1156``)."""

GAPS = (500.0, 700.0)
"""Their two runs' gaps (``arena_params``), one block of trials each."""


def arena_task(
    base: TaskSpec,
    layout: int,
    *,
    nest_radius: float = 500.0,
    food_radius: float = 500.0,
    points: int | None = None,
) -> TaskSpec:
    """``base`` (a foraging task, say) on the regions of the authors' arena ``layout``, named
    ``<base>-arena<layout>``, with the 2026 random start area; ``TaskError`` in one line for a layout this
    model version cannot run or a bad setting."""
    try:
        rows = [arena_entries(layout, nest_radius=nest_radius, food_radius=food_radius, gap=g, points=points)
                for g in GAPS]  # fmt: skip
    except ConfigError as error:
        raise TaskError(f"arena {layout}: {error}") from None
    kinds = sorted(
        {piece.kind for row in rows for entry in row for piece in entry} - {"nest"}, key=FOOD_KINDS.index
    )
    if set(kinds) - set(REGION_KINDS):
        raise TaskError(
            f"arena {layout} has the food kinds {', '.join(kinds)}; this model version runs one food kind "
            "(food): arenas 1-4, 7 and 8"
        )
    per_block = base.trials.chain_trials
    entries: list[ArenaEntry] = []
    for row in rows if rows[0] != rows[1] else rows[:1]:  # generated layouts do not change with the gap
        entries += [row[k % len(row)] for k in range(per_block if len(row) > 1 else 1)]
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
    return replace(
        base,
        name=f"{base.name}-arena{layout}",
        description=f"{base.name} on the regions of the authors' 2026 arena {layout} (their random start "
        "area; the rest of the model is the 2024 code's).",
        arena=Arena(half_size=base.arena.half_size, trial_entries=trial_entries),
        regions=regions,
        robots=replace(base.robots, start_half_size=START_HALF_2026),
    )


def _once(values: tuple) -> tuple:
    """``values``, or its one value when every entry has the same (a task file gives it once)."""
    return values[:1] if len(set(values)) == 1 else values
