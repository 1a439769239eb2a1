"""Benchmarks of bsdf-tab, run from a source checkout (never part of the installed package).

Scripts: ``accuracy.py`` (every integration method, error against time, judged by
``tests/reference``), ``compare_peers.py`` (the engine presets against the engines' shipped
tables), ``core.py`` (speed), ``load.py`` (the HTTP service under load). ``bsdf-tab bench NAME``
runs the first two from the checkout. Library modules: :mod:`bench.common` (cases, the
reference, one method run; shared by the sweep and the Mitsuba peer), :mod:`bench.accuracy_sweep`,
:mod:`bench.accuracy_figures`, :mod:`bench.mitsuba_peer` (Mitsuba's estimator) and
:mod:`bench.mitsuba_run` (the peer's benchmark run). Outputs go to ``bench/out/``.
"""
