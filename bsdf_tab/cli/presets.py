"""``bsdf-tab presets``: the engine presets and groups (bake one with ``bake --preset NAME``)."""

from __future__ import annotations

import argparse

NAME = "presets"
#: what the handler imports (``main.preload``: with the garbage collector paused)
IMPORTS = ("bsdf_tab.presets",)
HELP = "list the engine presets (bake one with bake --preset NAME)"


def configure(parser: argparse.ArgumentParser) -> None:
    """No arguments."""


def run(args: argparse.Namespace) -> int:
    """List the engine presets and groups."""
    from ..presets import GROUPS, PRESETS, describe

    for preset in PRESETS.values():
        print(describe(preset))
    for group, members in GROUPS.items():
        print(f"{group:<31} group: {', '.join(members)}")
    return 0
