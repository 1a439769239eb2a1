"""The table catalog: one compute function per table kind, and the registry that maps names to them.

A compute function takes the normalized spec, the resolved axes and a :class:`Context`, and
returns the table's channels (values and ``<X>_err`` error channels) shaped by the axes.
Adding a table kind: a module here, one line in :data:`COMPUTE`, one entry in
:data:`bsdf_tab.spec.TABLE_KINDS`.
"""

from __future__ import annotations

from . import albedo, bsdf, dielectric, dfg, multiscatter
from ._common import Context

COMPUTE = {
    "albedo": albedo.compute,
    "albedo_avg": albedo.compute_avg,
    "dielectric": dielectric.compute,
    "dielectric_avg": dielectric.compute_avg,
    "dfg": dfg.compute,
    "bsdf": bsdf.compute,
    "kulla_conty": multiscatter.compute,
}

__all__ = ["COMPUTE", "Context"]
