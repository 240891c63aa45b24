"""evolution_manager: see the package README and package.xml."""
