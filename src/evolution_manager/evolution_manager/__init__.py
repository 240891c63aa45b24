"""evolution_manager: evolving repertoires of behaviour trees, in wings (one subpackage per concern).

A wing may import the package's base modules (``errors``, ``files``, ``processes``, ``arguments``) and the
wings *below* it, never one above it (``test_wings.py`` checks it), and only through the modules another wing
names in its ``__all__``. From the bottom up:

1. ``evolution``: the algorithms (GP_o, GP_fnd, MAP-Elites) over DEAP trees, the archive, a run's
   configuration, the run loop and held-out scores. Ask/tell: it never calls the simulator itself.
2. ``recording``: rosbag2 bags with MCAP storage, written and read without ROS, and the check that a
   recorded trial reproduces.
3. ``viewing``: what a person opens: a run's result files and figures, trial frames and animations,
   snapshots, the repertoire explorer.
4. ``graph``: the ROS 2 side: node processes and their start-up, the manager, trial, recorder and replay
   nodes, and evaluations spread over evaluator nodes. The only wing that imports ``rclpy``.
5. ``cluster``: where the work runs beyond this machine's processes: a Dask scheduler, or Dask workers
   started as SLURM jobs; whole runs and a run's batches as tasks (``docs/cluster.md``). The only wing that
   imports Dask.
6. ``studies``: runs as a user starts them: ``evolve`` (one run), ``experiment`` (many), their statistics,
   the report and the benchmarks.
7. ``adaptation``: using a repertoire in a changed world (Intelligent Trial and Error) and its benchmark.

Wings to come (composition of primitives into foragers) take their place in this order by what
they import.
"""

WINGS = ("evolution", "recording", "viewing", "graph", "cluster", "studies", "adaptation")
"""The wings, bottom up: each may import the ones before it (``test/test_wings.py`` holds them to it)."""
