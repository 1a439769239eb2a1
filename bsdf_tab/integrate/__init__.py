"""Integration methods: one module per method, each a Warp kernel plus a thin host launcher."""

from .adaptive import integrate_texels

__all__ = ["integrate_texels"]
