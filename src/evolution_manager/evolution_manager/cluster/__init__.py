"""cluster: experiments and runs on a Dask cluster, beyond one machine (``docs/cluster.md``).

Where the work of ``experiment``, ``evolve``, ``adapt-benchmark`` and the main job runs: ``--cluster local``
(this machine's processes, the default), ``--cluster dask://HOST:PORT`` (the workers of a running Dask
scheduler) or ``--cluster slurm`` (Dask workers that dask-jobqueue starts as SLURM jobs, shaped by the YAML
file of ``--cluster-config``). An experiment sends whole runs as tasks (:func:`map_runs`); a single run sends
each batch as chunks of tens of evaluations (:class:`DaskEvaluator`). Results never depend on where they ran:
a result depends only on its request, and a run's files only on its configuration.

Modules: ``settings`` (the options, checked whole; imports no Dask), ``client`` (a checked ``Client``),
``runs`` (runs as tasks), ``evaluator`` (chunks of a batch as tasks), ``bench`` (the overhead benchmark).

Imports: this subpackage may import the run and experiment core of ``evolution_manager`` (``config``,
``errors``, ``experiment``, ``run``), ``swarm_sim.evaluation`` and the Dask libraries (``dask``,
``distributed``, ``dask_jobqueue``); nothing else of the package imports Dask. It is imported by the commands
that take ``--cluster`` and by nothing below them. ``settings`` is imported eagerly here (cheap); the others
load Dask and are loaded on first use of their names.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .settings import (
    CHUNK,
    ClusterError,
    ClusterSettings,
    SlurmSettings,
    add_cluster_options,
    parse_cluster,
    read_slurm_settings,
    settings_from_args,
)

if TYPE_CHECKING:
    from .client import open_client
    from .evaluator import DaskEvaluator
    from .runs import map_runs

__all__ = [
    "CHUNK",
    "ClusterError",
    "ClusterSettings",
    "DaskEvaluator",
    "SlurmSettings",
    "add_cluster_options",
    "map_runs",
    "open_client",
    "parse_cluster",
    "read_slurm_settings",
    "settings_from_args",
]

_LAZY = {"open_client": ".client", "DaskEvaluator": ".evaluator", "map_runs": ".runs"}


def __getattr__(name: str) -> Any:  # the Dask-backed names load Dask on first use (PEP 562)
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
