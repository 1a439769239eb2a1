"""Strict JSON text for spec and scene files: an object that repeats a key is an error naming the
key (JSON allows it and Python keeps the last; which one was meant is a guess)."""

from __future__ import annotations

import json

from .errors import SpecError

__all__ = ["loads", "unique_keys"]


def unique_keys(pairs: list) -> dict:
    """``json.loads`` hook: the object of ``pairs``, or a :class:`SpecError` naming a repeated key."""
    out = {}
    for key, value in pairs:
        if key in out:
            raise SpecError(None, f"the key {key[:60]!r} is given more than once in one JSON object; "
                                  "which one was meant is a guess: give it once")
        out[key] = value
    return out


def loads(text: str):
    """``json.loads`` with :func:`unique_keys` (``json.JSONDecodeError`` for invalid text)."""
    return json.loads(text, object_pairs_hook=unique_keys)
