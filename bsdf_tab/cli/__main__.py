"""``python -m bsdf_tab.cli``: the same as the ``bsdf-tab`` command."""

import sys

from .main import main

sys.exit(main())
