"""``bsdf-tab``: the parser built from the registered subcommands, and the error policy.

Errors are one line on stderr, ``bsdf-tab: error: <message>``, exit code 2 (1 for unexpected
internal errors; ``--debug`` shows their traceback); Ctrl-C exits with 130. Bad input is a
:class:`~.common.CliError` or a :class:`~bsdf_tab.errors.SpecError` (exit 2); any other exception,
a ``ValueError`` included, is an internal error (exit 1), so ``--debug`` can show its traceback.

Start-up: building the parser imports no table code (the subcommand modules import the spec,
the catalog and Warp inside their handlers). Before a handler runs, the modules it names in
its ``IMPORTS`` are imported with the garbage collector paused, then frozen (``gc.freeze``):
importing Warp and the kernel modules creates some 10^5 long-lived objects, and the full
collections that their growth triggers cost 0.2-0.3 s of a command's start (``docs/scenes.md``).
"""

from __future__ import annotations

import argparse
import gc
import importlib
import sys
from typing import Callable

from ..errors import SpecError
from . import bake, bench, check, info, plan, presets
from .common import PROG, CliError, OneLineParser

#: Subcommand name -> (help text, configure(parser), handler(args) -> int).
COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]] = {}

#: Entry-point group through which other packages add subcommands (``serve``).
ENTRY_POINT_GROUP = "bsdf_tab.commands"

#: Subcommand name -> the modules its handler needs (imported by :func:`preload`).
IMPORTS: dict[str, tuple[str, ...]] = {}


def register_command(name: str, help: str, configure: Callable, handler: Callable,
                     imports: tuple[str, ...] = ()) -> None:
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
    imports : tuple of str, optional
        Modules the handler needs: :func:`main` imports them before it runs (:func:`preload`).
    """
    COMMANDS[name] = (help, configure, handler)
    IMPORTS[name] = tuple(imports)


for _module in (bake, info, presets, plan, bench, check):
    register_command(_module.NAME, _module.HELP, _module.configure, _module.run, getattr(_module, "IMPORTS", ()))


def preload(modules) -> None:
    """Import ``modules`` with the garbage collector paused, then freeze what exists.

    Import-time objects live as long as the process, so the full collections their growth
    triggers find nothing to free; ``gc.freeze()`` then keeps them out of later collections.
    A module that fails to import is left to the handler, which reports it as usual."""
    if not modules:
        return
    enabled = gc.isenabled()
    gc.disable()
    try:
        for name in modules:
            try:
                importlib.import_module(name)
            except Exception:  # noqa: BLE001 - the handler's own import reports it
                break
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


def _load_plugins() -> None:
    """Subcommands of installed packages (entry points ``bsdf_tab.commands``: ``register(register_command)``)."""
    from importlib import metadata  # ~30 ms of imports: only when the plugins are needed

    for entry in metadata.entry_points(group=ENTRY_POINT_GROUP):
        if entry.name in COMMANDS:
            continue
        try:
            register = entry.load()
        except ImportError:  # the providing package is not importable here (e.g. a partial install)
            continue
        register(register_command)


_EVERY = object()  # build_parser(): configure every subcommand


def build_parser(only=_EVERY) -> argparse.ArgumentParser:
    """The argument parser with every registered subcommand.

    ``only``: the name of the one subcommand whose arguments are added (None: none); the
    others are listed with their help line only. :func:`main` passes the command named on its
    command line, so ``bsdf-tab --help`` or ``bsdf-tab plan ...`` never runs the other
    subcommands' ``configure`` (some import the formats, the doctor, NumPy). A built-in
    ``only`` skips the entry-point scan too (plugins never replace a built-in command)."""
    if only is _EVERY or only not in COMMANDS:
        _load_plugins()
    parser = OneLineParser(prog=PROG, description="Microfacet BSDF lookup tables with error estimates.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (help_text, configure, handler) in COMMANDS.items():
        sp = sub.add_parser(name, help=help_text, description=help_text)
        if only is _EVERY or only == name:
            configure(sp)
            sp.set_defaults(handler=handler)
    return parser


def _command_in(argv: list[str]) -> str | None:
    """The subcommand named in ``argv`` (the first word that is not a top-level option)."""
    for word in argv:
        if word == "--debug":
            continue
        return None if word.startswith("-") else word
    return None


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
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(only=_command_in(argv))
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help (0) or a usage error (2)
        return int(exc.code or 0)
    if not getattr(args, "handler", None):
        parser.print_help(sys.stderr)
        return 2
    try:
        preload(IMPORTS.get(args.command, ()))
        return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like: stop quietly
        _silence_stdout()
        return 0
    except (CliError, SpecError) as exc:  # bad input: the handlers raise these (never a bare ValueError)
        return _error(str(exc), 2)
    except OSError as exc:
        return _error(_os_message(exc), 2)
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback by default
        if args.debug:
            raise
        return _error(f"internal error: {type(exc).__name__}: {exc} (run with --debug for details)", 1)


if __name__ == "__main__":
    sys.exit(main())
