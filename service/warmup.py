"""Compile (or load) the Warp kernels of every table kind: one tiny table each.

``python -m service.warmup`` runs it (the Dockerfile does, at build time, with
``WARP_CACHE_PATH`` pointing into the image); the service runs it at start-up in the background.
"""

from __future__ import annotations

import logging
import sys

log = logging.getLogger("bsdf_tab.service")


def tiny_spec(kind: str) -> dict:
    """A one-texel spec of ``kind``: each axis at the middle of its default range."""
    from bsdf_tab.spec import AXIS_DEFAULTS, TABLE_KINDS

    axes = {a: [0.5 * sum(AXIS_DEFAULTS[a]["range"])] for a in TABLE_KINDS[kind]["axes"]}
    return {"table": kind, "axes": axes}


def warm_kinds() -> list[str]:
    """The kinds to warm, in catalog order (the core kinds, albedo first, lead it)."""
    from bsdf_tab.spec import TABLE_KINDS

    return list(TABLE_KINDS)


def warm_kind(kind: str, device: str | None = None, strict: bool = False) -> bool:
    """Tabulate a tiny table of ``kind`` (its kernels compile, or load from Warp's cache);
    True when it worked."""
    import bsdf_tab

    try:
        bsdf_tab.tabulate(tiny_spec(kind), device=device, workers=1)
        return True
    except Exception as exc:  # noqa: BLE001 - warm-up is best effort unless strict
        if strict:
            raise
        log.warning("warm-up of %s failed: %s", kind, exc)
        return False


def warm_all(device: str | None = None, strict: bool = False) -> list[str]:
    """Tabulate a tiny table of every kind; returns the kinds that worked."""
    return [kind for kind in warm_kinds() if warm_kind(kind, device, strict)]


if __name__ == "__main__":
    kinds = warm_all(device=sys.argv[1] if len(sys.argv) > 1 else None, strict=True)
    print("compiled Warp kernels for:", ", ".join(kinds))
