"""How the service serves a table: each variant's bytes made from the master table.

The file formats are :mod:`bsdf_tab.io`'s (one meaning per name, the same bytes the CLI writes);
``info`` is the service's own summary, with the storage error of each served format.
"""

from __future__ import annotations

import json

import numpy as np

import bsdf_tab.io as bsdf_io
from bsdf_tab.io import json_default
from bsdf_tab.io.json import finite_json
from bsdf_tab.io.storage import storage_report_for_format
from bsdf_tab.table import Table

__all__ = ["DERIVE", "MASTER", "to_exr", "to_info", "to_json", "to_npy"]

#: the variant kept in the cache, from which the others are derived
MASTER = "npz"

def to_exr(table: Table) -> bytes:
    """The float32 EXR file (:mod:`bsdf_tab.io.exr`)."""
    return bsdf_io.to_bytes(table, "exr")


def to_npy(table: Table) -> bytes:
    """One structured ``.npy`` array shaped by the axes, a float64 field per channel.

    (:mod:`bsdf_tab.io.npy`; ``np.load(..., allow_pickle=False)`` reads it; axes are in the
    npz / JSON / EXR forms.)
    """
    return bsdf_io.to_bytes(table, "npy")


def to_json(table: Table) -> bytes:
    """The table as strict, compact JSON (:mod:`bsdf_tab.io.json`)."""
    return bsdf_io.to_bytes(table, "json")


def to_info(table: Table) -> bytes:
    """Metadata without the data: spec, conventions, method, max error, axes summary."""
    meta = finite_json(json.loads(json.dumps(table.meta, default=json_default)))
    info = {
        "table": table.kind,
        "shape": list(table.shape),
        "axes": {
            n: {"size": int(len(a)), "min": float(a.min()), "max": float(a.max())} for n, a in table.axes.items()
        },
        "channels": list(table.channels),
        "max_error": {k: (v if np.isfinite(v) else None) for k, v in table.max_error().items()},
        "conventions": meta.get("conventions"),
        "method": meta.get("method"),
        # what each served format's storage adds to the integration error (bsdf_tab.io.storage)
        "storage": {fmt: finite_json(storage_report_for_format(table, fmt)) for fmt in ("exr", "npz", "json")},
        "spec": meta.get("spec"),
        "version": meta.get("version"),
    }
    return json.dumps(info, allow_nan=False).encode()


#: variant -> how it is made from the master table (the master itself is ``MASTER``)
DERIVE = {"exr": to_exr, "npy": to_npy, "json": to_json, "info": to_info}
