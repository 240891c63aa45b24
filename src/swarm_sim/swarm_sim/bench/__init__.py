"""Benchmarks: ``batch`` times the batch road against the reference road, ``recording`` the recordings;
``division`` measures hand-written foragers on the balanced task (does a division of labour pay?)."""
