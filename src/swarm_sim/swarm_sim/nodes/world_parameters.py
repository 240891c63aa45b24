"""The world's parameters as a node declares them: one per field of ``swarm_sim.model.config.Config``
(``swarm_ros.parameters.declare_dataclass``), but a layout of regions, which ROS parameters cannot hold as
nested lists, is one JSON text (``layout``; empty: the papers' arena of ``nest_radius`` and ``gaps``), and so
are the robot groups' food kinds (``carries``; empty: every robot carries every kind), and
per-robot faults (``swarm_sim.model.faults``) come only through the simulator's ``conditions`` parameter.
The simulator and the evaluator declare the world the same way."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from rclpy.node import Node

from swarm_ros.parameters import declare, declare_dataclass, descriptor
from swarm_sim.model import (
    FAULT_FIELDS,
    Config,
    carries_from_text,
    carries_to_text,
    layout_from_text,
    layout_to_text,
)

LAYOUT_DESCRIPTION = (
    "the regions of every trial as JSON (swarm_sim.model.regions, docs/tasks.md); empty: the papers' arena "
    "of nest_radius and gaps"
)
CARRIES_DESCRIPTION = (
    "which food kinds each robot group picks up, as JSON: one list of kind names per group, robot i in group "
    "i mod groups (docs/tasks.md, robots.carries); empty: every robot picks up every kind"
)


def declare_world(
    node: Node, config: Config, *, ranges: Mapping[str, tuple[float, float]] | None = None
) -> Config:
    """Declare the world's parameters on ``node`` (read-only, defaults from ``config``) and return the world
    they give; ``ConfigError`` or ``ParameterError`` in one line for a bad one."""
    text: str = declare(
        node, "layout", layout_to_text(config.layout), descriptor(LAYOUT_DESCRIPTION, read_only=True)
    )
    # The layout first: the other parameters are checked against it (a formation needs its discs).
    carries: str = declare(
        node, "carries", carries_to_text(config.carries), descriptor(CARRIES_DESCRIPTION, read_only=True)
    )
    laid_out = replace(config, layout=layout_from_text(text), carries=carries_from_text(carries))
    skip = ("layout", "carries", *FAULT_FIELDS)  # faults come through the conditions parameter
    return declare_dataclass(node, laid_out, read_only=True, ranges=ranges, skip=skip)
