"""The world model as plain data, free of compiled code: settings, objectives, conditions, swarm layouts and
arenas.

``Config`` (``config``) holds every parameter of the model, validated once; the objectives and descriptors
are a table (``objectives``); conditions are named changes to a ``Config`` (``conditions``), per-robot
faults among them (``faults``); a swarm layout gives each robot its tree (``swarm_layout``); the nest and food
are pieces of ground (``regions``), and the authors' 2026 arena layouts 1-9 are made of them (``arenas``).
Other packages import these names from here.
"""

from swarm_sim.model.arenas import (
    FOOD_KINDS,
    GENERATED_LAYOUTS,
    arena_entries,
    pieces_from_points,
    scatter_points,
)
from swarm_sim.model.conditions import CONDITION_NAMES, apply_conditions, condition_texts
from swarm_sim.model.config import (
    DEFAULT,
    Config,
    Params,
    carries_from_text,
    carries_to_text,
    config_from_dict,
    default_config,
)
from swarm_sim.model.faults import CONFIG_FIELDS as FAULT_FIELDS
from swarm_sim.model.faults import FAULT_KINDS, fault_kinds_of, parse_fault_pairs
from swarm_sim.model.objectives import (
    DESCRIPTORS,
    FAMILIES,
    N_OBJECTIVES,
    N_PROBES,
    N_VALUES,
    OBJECTIVE_TABLE,
    OBJECTIVES,
    PAPER_OBJECTIVES,
    PROBES,
    VALUE_NAMES,
    Objective,
    fitness_ceiling,
)
from swarm_sim.model.regions import (
    PIECE_SHAPES,
    REGION_KINDS,
    Piece,
    concentric,
    label_point,
    layout_from_text,
    layout_to_text,
)
from swarm_sim.model.swarm_layout import (
    LayoutError,
    SwarmLayout,
    layout_from_json,
    layout_of_label,
    load_layout,
    of_trees,
)

__all__ = [
    "CONDITION_NAMES",
    "DEFAULT",
    "DESCRIPTORS",
    "FAMILIES",
    "FAULT_FIELDS",
    "FAULT_KINDS",
    "FOOD_KINDS",
    "GENERATED_LAYOUTS",
    "N_OBJECTIVES",
    "N_PROBES",
    "N_VALUES",
    "OBJECTIVES",
    "OBJECTIVE_TABLE",
    "PAPER_OBJECTIVES",
    "PIECE_SHAPES",
    "PROBES",
    "REGION_KINDS",
    "VALUE_NAMES",
    "Config",
    "LayoutError",
    "Objective",
    "Params",
    "Piece",
    "SwarmLayout",
    "apply_conditions",
    "arena_entries",
    "carries_from_text",
    "carries_to_text",
    "concentric",
    "condition_texts",
    "config_from_dict",
    "default_config",
    "fault_kinds_of",
    "fitness_ceiling",
    "label_point",
    "layout_from_json",
    "layout_from_text",
    "layout_of_label",
    "layout_to_text",
    "load_layout",
    "of_trees",
    "parse_fault_pairs",
    "pieces_from_points",
    "scatter_points",
]
