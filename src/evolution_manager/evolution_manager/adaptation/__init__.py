"""Using a repertoire: recover from damage or a changed world in a few trials (Intelligent Trial and Error).

``search`` is the Bayesian search over a repertoire's bins, for every robot or only the robots a condition
strikes; ``adapt`` is the command (in-process, or through the node graph with ``--graph``);
``adapt_benchmark`` compares it with its baselines on the conditions where the repertoire's best tree falls
below 70 % of its fault-free score; ``live`` decides a live adaptation of a running swarm (windows, faults,
the trees swapped in) and ``adapt_live`` is its command, through the node graph. Imports: the base modules
and every wing below it (``graph`` only for ``adapt --graph`` and ``adapt-live``).
"""

__all__ = ["adapt", "adapt_benchmark", "adapt_live", "live", "search"]
