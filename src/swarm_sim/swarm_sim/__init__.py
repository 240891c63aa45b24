"""swarm_sim: see the package README and package.xml."""
