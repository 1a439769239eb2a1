"""``bsdf-tab serve``: added to the library's CLI through the ``bsdf_tab.commands`` entry point (imports nothing heavy until run)."""

from __future__ import annotations

import argparse

from bsdf_tab.cli.common import CliError

__all__ = ["register"]


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", default=None, help="interface to listen on (default 127.0.0.1, or BSDF_TAB_HOST)")
    parser.add_argument("--port", type=int, default=None, help="port (default 8000, or BSDF_TAB_PORT)")
    parser.add_argument("--cache-dir", default=None, help="cache folder (default ~/.cache/bsdf-tab/service)")
    parser.add_argument("--workers", type=int, default=None, help="CPU threads per computation (default: all)")
    parser.add_argument("--max-concurrent", type=int, default=None, help="computations at a time (default 1)")
    parser.add_argument("--max-texels", type=int, default=None, help="largest table served (default 262144)")
    parser.add_argument("--header-timeout", type=float, default=None,
                        help="seconds to receive a request's headers (default 10, or BSDF_TAB_HEADER_TIMEOUT)")
    parser.add_argument("--max-cost-seconds", type=float, default=None,
                        help="predicted core-seconds of a synchronous request (default 60; more: 413, use a job)")
    parser.add_argument("--no-warmup", action="store_true", help="do not load the Warp kernels at start-up")
    parser.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"])


def _serve(args: argparse.Namespace) -> int:
    from .app import create_app
    from .server import run
    from .settings import Settings

    overrides = {
        "host": args.host,
        "port": args.port,
        "cache_dir": args.cache_dir,
        "workers": args.workers,
        "max_concurrent": args.max_concurrent,
        "max_texels": args.max_texels,
        "header_timeout": args.header_timeout,
        "max_cost_seconds": args.max_cost_seconds,
    }
    if args.no_warmup:
        overrides["warmup"] = False
    try:
        settings = Settings(**{k: v for k, v in overrides.items() if v is not None})
    except ValueError as exc:  # pydantic ValidationError: one line per field
        errors = getattr(exc, "errors", lambda: [])()
        text = "; ".join(f"--{'-'.join(str(x) for x in e['loc']).replace('_', '-')}: {e['msg']}" for e in errors)
        raise CliError(text or str(exc)) from None
    app = create_app(settings)
    try:
        app.state.store.cache.check_folder()  # a file or unwritable folder: one line, exit 2, before listening
    except ValueError as exc:
        raise CliError(f"--cache-dir: {exc}") from None
    run(app, settings, log_level=args.log_level)
    return 0


def register(register_command) -> None:
    """Add ``serve`` to the ``bsdf-tab`` command: the ``bsdf_tab.commands`` entry point (pyproject.toml)."""
    # the app's modules (FastAPI, the table code, Warp) are imported by `bsdf-tab` before _serve
    # runs, with the garbage collector paused (bsdf_tab.cli.main.preload)
    register_command("serve", "run the HTTP service (FastAPI on uvicorn)", _configure, _serve,
                     imports=("service.app", "service.server"))
