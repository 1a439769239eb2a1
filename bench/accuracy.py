"""Accuracy against speed for every integration method (see bsdf_tab/benchmarks/accuracy.py).

Run: ``python bench/accuracy.py`` (full sweep, several minutes) or ``--quick`` (about a minute).
Writes bench/out/accuracy[_quick].json, .png (error vs time, Pareto front, peers) and
_heatmaps.png (error over (mu, alpha) per method). Same as ``bsdf-tab bench accuracy``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bsdf_tab.benchmarks.accuracy import configure_parser, main_from_args  # noqa: E402

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    configure_parser(parser)
    sys.exit(main_from_args(parser.parse_args()))
