"""Former name of :mod:`bsdf_tab.integrate.runtime` (kept while callers move to it)."""

from .runtime import ProgressFn, check_workers, default_workers, resolve_device, run_chunks, texel_arrays

__all__ = ["ProgressFn", "check_workers", "default_workers", "resolve_device", "run_chunks", "texel_arrays"]
