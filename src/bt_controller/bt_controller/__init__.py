"""bt_controller: see the package README and package.xml."""
