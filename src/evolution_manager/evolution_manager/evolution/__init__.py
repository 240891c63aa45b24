"""The evolutionary algorithms and everything a run is made of, with no ROS and no drawing.

The paper's parameters (``parameters``), DEAP's primitive set and the conversion between DEAP trees and tree
text (``deap_trees``), the genetic operators (``operators``), GP_o, GP_fnd and MAP-Elites as ask/tell
algorithms (``algorithms``), the grids and repertoires (``archive`` over qdpy, ``qdpy_grid``) and the
behaviour spaces they bin trees by (``descriptor_sets``), a run's
configuration and command-line options (``run_config``, ``options``), the run folder and run loop that
tree runs and composition runs share (``run_folder``), a tree run with its checkpoints (``run``), the
held-out scores (``heldout``), trees as people are shown them (``shown_trees``), what a run's result files
show, computed (``run_results``), and primitive libraries made from runs' repertoires (``libraries``, the
``library`` command), and heterogeneous compositions of repertoire cells evolved by a GA or MAP-Elites
(``compositions``), the optimisers over a neural controller's weights, CMA-ES, the authors' GA and
MAP-Elites (``networks``), and teams, K trees evolved together by the GP, robot i running tree i mod K
(``teams``), and the validated choice that ends a composition or team run: its best candidates
re-scored on validation scenarios (``validation``). Imports: the base modules, bt_controller, swarm_sim,
DEAP, qdpy, pycma and pyribs; no other wing.
"""

__all__ = [
    "algorithms",
    "archive",
    "compositions",
    "deap_trees",
    "descriptor_sets",
    "heldout",
    "libraries",
    "networks",
    "operators",
    "options",
    "run",
    "run_config",
    "run_folder",
    "run_results",
    "shown_trees",
    "teams",
    "validation",
]
