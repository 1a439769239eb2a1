"""The benchmarks (``bench/``) and the reference (``tests/reference``) are imported from the
checkout: its root goes on ``sys.path`` (plain ``pytest`` does not put it there)."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
