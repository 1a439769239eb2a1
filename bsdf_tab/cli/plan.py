"""``bsdf-tab plan SCENE --tol T``: print the minimal tables of a scene (``docs/scenes.md``).

Also the scene side of ``bsdf-tab bake SCENE --tol T -o DIR`` (:func:`bake_scene`, called by
:mod:`.bake` when :func:`is_scene_file`): the same plan, baked as EXR tables and
``manifest.json``. Progress (one line per verified candidate) goes to stderr unless ``-q``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import SpecError
from .common import CliError, check_device, check_workers, quiet_warp

if TYPE_CHECKING:
    from ..scene import ScenePlan

# The scene package (the spec, the table catalog, Warp) is imported when a command runs, not
# when the parser is built: ``bsdf-tab --help`` stays cheap.

NAME = "plan"
#: what the handler imports (``main.preload``: with the garbage collector paused)
IMPORTS = ("bsdf_tab.scene", "bsdf_tab.api")
HELP = "plan the minimal tables of a scene file for a lookup error (--tol T)"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="scene file, JSON or .toml (a 'materials' list; docs/scenes.md)")
    parser.add_argument("--tol", type=float, default=None, help="max lookup error (default: the scene's tolerance)")
    parser.add_argument("--json", action="store_true", help="print the plan as JSON")
    parser.add_argument("--device", default=None, help="Warp device (default: Warp's)")
    parser.add_argument("--workers", type=int, default=None, help="number of parallel workers")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines on stderr")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS|local:N",
                        help="compute the candidate tables on a Dask cluster (default: $BSDF_TAB_SCHEDULER)")


def run(args: argparse.Namespace) -> int:
    """``bsdf-tab plan SCENE --tol T``: print the plan (text, or JSON with ``--json``)."""
    plan = _plan(args, args.scene)
    if args.json:
        from ..io import json_default


        print(json.dumps(plan.to_dict(), indent=2, default=json_default))
    else:
        print(plan.text())
    return 0


def is_scene_file(path: str) -> bool:
    """A spec path that holds a scene (top-level 'materials'; JSON or .toml), not one table's spec."""
    if Path(path).suffix.lower() == ".toml":
        return True  # table specs are JSON; the scene loader reports what is wrong with it
    from ..scene import is_scene, load_scene_file

    try:
        return is_scene(load_scene_file(path, strict=False))  # the scene loader reports a repeated key
    except SpecError:
        return False  # the spec loader reports it


def bake_scene(args: argparse.Namespace) -> int:
    """``bsdf-tab bake SCENE --tol T -o DIR``: plan the scene, write its tables and manifest.json.

    Reads ``args.spec`` (the scene file), ``tol``, ``output``, ``device``, ``workers``, ``quiet``.
    """
    if not args.output:
        raise CliError("give -o DIR: the folder for the scene's tables and manifest.json")
    from ..scene import bake_scene as write_scene

    plan = _plan(args, args.spec)
    path = write_scene(plan, args.output)  # SpecError "output: ..." if it is not a folder
    print(plan.text())
    print(f"wrote {len(plan.tables)} table(s) and {path}")
    return 0


def _plan(args: argparse.Namespace, path: str) -> ScenePlan:
    from ..scene import is_scene, load_scene_file, plan_scene

    check_workers(args)
    try:
        scene = load_scene_file(path)
    except SpecError as exc:
        raise CliError(str(exc)) from None
    if not is_scene(scene):
        raise CliError(f"{path} is not a scene (no top-level 'materials' list)")
    quiet_warp(args)

    def log(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    from .many import connect_cluster, scheduler_of

    scheduler = scheduler_of(args)
    check_device(args, scheduler)
    client, owned = connect_cluster(scheduler) if scheduler else (None, False)
    try:
        return plan_scene(scene, args.tol, device=args.device, workers=args.workers,
                          log=None if args.quiet else log, scheduler=client)
    except SpecError as exc:
        raise CliError(f"{path}: {exc}") from None
    finally:
        if owned:
            from ..cluster import close

            close(client)
