"""The ``bsdf-tab`` command line: a thin shell over the library, one module per subcommand.

``bake`` (:mod:`.bake`), ``info`` (:mod:`.info`), ``presets`` (:mod:`.presets`), ``plan``
(:mod:`.plan`) and ``bench`` (:mod:`.bench`) are built in; other packages add subcommands
through the ``bsdf_tab.commands`` entry-point group (the HTTP service adds ``serve``), so the
library never imports them. Errors are one line on stderr and exit code 2.
"""

from .common import CliError
from .main import COMMANDS, build_parser, main, register_command

__all__ = ["COMMANDS", "CliError", "build_parser", "main", "register_command"]
