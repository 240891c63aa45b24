"""Experiments and runs on a Dask cluster, beyond one machine (``docs/cluster.md``).

Where the work of ``experiment``, ``evolve``, ``adapt-benchmark`` and the main job runs: ``--cluster local``
(this machine's processes, the default), ``--cluster dask://HOST:PORT`` (the workers of a running Dask
scheduler) or ``--cluster slurm`` (Dask workers that dask-jobqueue starts as SLURM jobs, shaped by the YAML
file of ``--cluster-config``). The options, checked whole and without loading Dask (``settings``); a checked
client, and under SLURM the jobs kept at their count (``client``); whole runs of an experiment as tasks, with
the run function the caller hands over (``runs``); a single run's batches as chunks, one per worker thread
(``evaluator``: ``DaskEvaluator``). Results never depend on where they ran: a result depends only on its
request, and a run's files only on its configuration.

Imports: the base modules (``errors``), the ``evolution`` wing, ``swarm_sim``'s evaluator and the Dask
libraries (``dask``, ``distributed``, ``dask_jobqueue``), no other wing. The ``studies`` and ``adaptation``
commands above it take ``--cluster`` through it; it is the only wing that imports Dask.
"""

__all__ = ["client", "evaluator", "runs", "settings"]
