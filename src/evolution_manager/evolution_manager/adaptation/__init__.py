"""Using a repertoire: recover from damage or a changed world in a few trials (Intelligent Trial and Error).

``search`` is the Bayesian search over a repertoire's bins; ``adapt`` is the command (in-process, or through
the node graph with ``--graph``); ``adapt_benchmark`` compares it with its baselines; ``live`` decides a live
adaptation of a running swarm (windows, faults, the trees swapped in) and ``adapt_live`` is its command,
through the node graph. Imports: the base modules and every wing below it (``graph`` only for ``adapt
--graph`` and ``adapt-live``).
"""

__all__ = ["adapt", "adapt_benchmark", "adapt_live", "live", "search"]
