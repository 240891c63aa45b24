"""Benchmarks: ``batch`` times the batch road against the reference road, ``recording`` the recordings."""
