"""Strict JSON text for spec and scene files: an object that repeats a key is an error naming the
key (JSON allows it and Python keeps the last; which one was meant is a guess)."""

from __future__ import annotations

import json

from .errors import SpecError

__all__ = ["RepeatedKey", "loads", "unique_keys"]


class RepeatedKey(SpecError):
    """A JSON object that gives ``key`` more than once (the service names it ``body.<key>``)."""

    def __init__(self, key: str) -> None:
        self.key = key[:60]
        super().__init__(None, f"the key {self.key!r} is given more than once in one JSON object; "
                               "which one was meant is a guess: give it once")

    def __reduce__(self):
        return (type(self), (self.key,))


def unique_keys(pairs: list) -> dict:
    """``json.loads`` hook: the object of ``pairs``, or :class:`RepeatedKey`."""
    out = {}
    for key, value in pairs:
        if key in out:
            raise RepeatedKey(key)
        out[key] = value
    return out


def loads(text: str | bytes):
    """``json.loads`` with :func:`unique_keys` (``json.JSONDecodeError`` for invalid text)."""
    return json.loads(text, object_pairs_hook=unique_keys)
