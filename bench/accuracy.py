"""Accuracy against speed for every integration method (the code: bench/accuracy_sweep.py).

Run: ``python bench/accuracy.py`` (full sweep, several minutes) or ``--quick`` (about a minute).
Writes bench/out/accuracy[_quick].json, .png (error vs time, Pareto front, peers) and
_heatmaps.png (error over (mu, alpha) per method). Same as ``bsdf-tab bench accuracy``, which
calls :func:`main` with its own ``prog``.
"""

from __future__ import annotations

import sys
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from bench.accuracy_sweep import main  # noqa: E402

__all__ = ["main"]

if __name__ == "__main__":
    try:
        sys.exit(main())
    except (ValueError, RuntimeError) as exc:
        print(f"{Path(sys.argv[0]).name}: error: {exc}", file=sys.stderr)
        sys.exit(2)
