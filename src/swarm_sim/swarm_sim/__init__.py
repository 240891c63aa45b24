"""swarm_sim: the footbot swarm of ``docs/model.md``, one concept per folder (see the package README).

``model`` (settings, objectives, conditions, swarm layouts: plain data), ``tasks`` (task specs and their
registry), ``core`` (the compiled trial-step core and batch kernels), ``roads`` (the lockstep chain, the
reference road, recordings), ``evaluation`` (the Evaluator contract and results as messages), ``validation``
(against the authors' ARGoS), ``bench`` (benchmarks) and ``nodes`` (the ROS 2 nodes). Importing this package
imports none of them.
"""
