"""Using a repertoire: recover from damage or a changed world in a few trials (Intelligent Trial and Error).

``search`` is the Bayesian search over a repertoire's bins; ``adapt`` is the command (in-process, or through
the node graph with ``--graph``); ``adapt_benchmark`` compares it with its baselines. Imports: the base
modules and every wing below it (``graph`` only for ``adapt --graph``).
"""

__all__ = ["adapt", "adapt_benchmark", "search"]
