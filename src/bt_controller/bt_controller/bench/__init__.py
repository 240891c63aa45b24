"""Benchmarks and measurements, never tests: ``tick_bench`` times the compiled interpreter and the parser (the
``bench`` command), ``simplify_measure`` counts how much the simplifier shrinks real trees."""
