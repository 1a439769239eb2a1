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

from ..errors import SpecError
from ..scene import ScenePlan, is_scene, load_scene_file, plan_scene
from ..scene import bake_scene as write_scene
from ..io import json_default
from .common import CliError, check_workers, quiet_warp

NAME = "plan"
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
        print(json.dumps(plan.to_dict(), indent=2, default=json_default))
    else:
        print(plan.text())
    return 0


def is_scene_file(path: str) -> bool:
    """A spec path that holds a scene (top-level 'materials'; JSON or .toml), not one table's spec."""
    if Path(path).suffix.lower() == ".toml":
        return True  # table specs are JSON; the scene loader reports what is wrong with it
    try:
        return is_scene(load_scene_file(path))
    except SpecError:
        return False  # the spec loader reports it


def bake_scene(args: argparse.Namespace) -> int:
    """``bsdf-tab bake SCENE --tol T -o DIR``: plan the scene, write its tables and manifest.json.

    Reads ``args.spec`` (the scene file), ``tol``, ``output``, ``device``, ``workers``, ``quiet``.
    """
    if not args.output:
        raise CliError("give -o DIR: the folder for the scene's tables and manifest.json")
    plan = _plan(args, args.spec)
    path = write_scene(plan, args.output)  # SpecError "output: ..." if it is not a folder
    print(plan.text())
    print(f"wrote {len(plan.tables)} table(s) and {path}")
    return 0


def _plan(args: argparse.Namespace, path: str) -> ScenePlan:
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
