"""Benchmarks importable from the package (run them with ``bsdf-tab bench NAME``)."""
