"""Runs as a user starts them, and what is learnt from many.

``evolve`` runs one algorithm in-process and writes its run directory; ``experiment`` runs every algorithm x
objective x repetition (resumable) and ``report`` turns the runs into the paper's table 6 and figures, with
the tests of ``significance``; ``measure`` is the evolution benchmark. Imports: the base modules and the
``evolution``, ``recording`` and ``viewing`` wings; no ROS.
"""

__all__ = ["evolve", "experiment", "measure", "report", "significance"]
