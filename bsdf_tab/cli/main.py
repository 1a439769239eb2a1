"""``bsdf-tab``: the parser built from the registered subcommands, and the error policy.

Errors are one line on stderr, ``bsdf-tab: error: <message>``, exit code 2 (1 for unexpected
internal errors; ``--debug`` shows their traceback); Ctrl-C exits with 130.
"""

from __future__ import annotations

import argparse
import sys
from importlib import metadata
from typing import Callable

from ..errors import SpecError
from . import bake, bench, check, info, plan, presets
from .common import PROG, CliError

#: Subcommand name -> (help text, configure(parser), handler(args) -> int).
COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]] = {}

#: Entry-point group through which other packages add subcommands (``serve``).
ENTRY_POINT_GROUP = "bsdf_tab.commands"


def register_command(name: str, help: str, configure: Callable, handler: Callable) -> None:
    """Add a subcommand.

    Parameters
    ----------
    name : str
        Subcommand name.
    help : str
        One-line help text.
    configure : callable
        ``configure(parser)`` adds the subcommand's arguments.
    handler : callable
        ``handler(args) -> int`` runs it and returns the exit code.
    """
    COMMANDS[name] = (help, configure, handler)


for _module in (bake, info, presets, plan, bench, check):
    register_command(_module.NAME, _module.HELP, _module.configure, _module.run)


def _load_plugins() -> None:
    """Subcommands of installed packages (entry points ``bsdf_tab.commands``: ``register(register_command)``)."""
    for entry in metadata.entry_points(group=ENTRY_POINT_GROUP):
        if entry.name in COMMANDS:
            continue
        try:
            register = entry.load()
        except ImportError:  # the providing package is not importable here (e.g. a partial install)
            continue
        register(register_command)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered subcommand."""
    _load_plugins()
    parser = argparse.ArgumentParser(prog=PROG, description="Microfacet BSDF lookup tables with error estimates.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (help_text, configure, handler) in COMMANDS.items():
        sp = sub.add_parser(name, help=help_text, description=help_text)
        configure(sp)
        sp.set_defaults(handler=handler)
    return parser


def _one_line(message: str) -> str:
    return " ".join(str(message).split()) or "unknown error"


def _error(message: str, code: int) -> int:
    print(f"{PROG}: error: {_one_line(message)}", file=sys.stderr)
    return code


def _os_message(exc: OSError) -> str:
    if exc.strerror and exc.filename:
        return f"{exc.strerror}: {exc.filename}"
    return str(exc)


def _silence_stdout() -> None:
    import os

    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout is not a real file (tests)
        pass


def main(argv: list[str] | None = None) -> int:
    """Run the ``bsdf-tab`` command.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit code: 0 success, 2 usage or input error, 1 internal error, 130 interrupted.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help (0) or a usage error (2)
        return int(exc.code or 0)
    if not getattr(args, "handler", None):
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like: stop quietly
        _silence_stdout()
        return 0
    except (CliError, SpecError, ValueError) as exc:
        return _error(str(exc), 2)
    except OSError as exc:
        return _error(_os_message(exc), 2)
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback by default
        if args.debug:
            raise
        return _error(f"internal error: {type(exc).__name__}: {exc} (run with --debug for details)", 1)


if __name__ == "__main__":
    sys.exit(main())
