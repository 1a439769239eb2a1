"""What the GPU texture formats share (``ktx2``, ``dds``, ``png``): image shape, components,
the lookup convention, and the metadata they carry.

Layout
------
The value channels of a table become the components of one texture, in channel order
(channel 0 -> R, 1 -> G, 2 -> B, 3 -> A); error channels are not stored (their maxima and the
storage error are in the metadata, :mod:`bsdf_tab.io.storage`). Axes map to texture
coordinates last-axis-fastest, as in every other bsdf-tab format:

- 1-D (a0): width len(a0) (one row);
- 2-D (a0, a1): height len(a0), width len(a1); texel (x, y) = channel[y, x], row y = 0 first
  in memory (texture coordinate v = (y + 0.5) / height);
- 3-D (a0, a1, a2): a volume, depth len(a0), height len(a1), width len(a2); ``png`` (no
  volumes) stacks the a0 slices vertically, row = i0 * len(a1) + i1.

Texel centres carry the nodes: the node of index i along an axis of n nodes is at normalized
coordinate (i + 0.5) / n. :func:`lookup_convention` says, per axis, how a shader maps an axis
value to that coordinate (``u = (a - a_0) / (a_last - a_0) * (n - 1) / n + 0.5 / n`` for an axis
with equal steps; otherwise the fractional index in the stored axis values). Its numbers are
plain decimal literals (``0.08333333333333333``, ``11.0``), so each right-hand side evaluates as
written in Python, GLSL or HLSL.

A 3-D table in a ``png`` (``layout="stacked"``): axis a0 is no texture axis. Its
``coordinate`` is the fractional slice index ``slice`` in [0, n0 - 1]; axis a1's is
``v = (i_a0 * n1 + k1 + 0.5) / (n0 * n1)`` for the integer slice ``i_a0`` (k1 the fractional
index of a1, in [0, n1 - 1]), so v stays between the centres of that slice's first and last
rows and linear filtering never mixes two slices; a shader samples slices floor(slice) and
floor(slice) + 1 and mixes them itself. ``bsdf_tab_lookup["layout"]`` says which texel holds
which node.
"""

from __future__ import annotations

import json

import numpy as np

from .base import ERR_SUFFIX, json_default, shape_of, value_channels

__all__ = [
    "COMPONENTS",
    "TEXTURE_FORMATS",
    "image_dims",
    "lookup_convention",
    "metadata_strings",
    "parts_from_metadata",
    "texel_array",
    "table_from_texels",
]

#: Component letters, in order.
COMPONENTS = "RGBA"

#: The registry formats written from this module: they store value channels only (no ``_err``).
TEXTURE_FORMATS = ("ktx2", "dds", "png")


def image_dims(table) -> tuple[int, int, int]:
    """(width, height, depth) of the texture of ``table``; height and depth 0 when absent.

    Raises
    ------
    ValueError
        For a table of more than 3 axes.
    """
    shape = shape_of(table)
    if len(shape) == 1:
        return shape[0], 0, 0
    if len(shape) == 2:
        return shape[1], shape[0], 0
    if len(shape) == 3:
        return shape[2], shape[1], shape[0]
    raise ValueError(f"a texture holds tables of 1 to 3 axes, this one has {len(shape)}")


def texel_array(table, stored: dict[str, np.ndarray]) -> np.ndarray:
    """The stored value channels as one array (*shape, n_components), channels last.

    Raises
    ------
    ValueError
        With no value channel or more than 4.
    """
    names = value_channels(table.channels)
    if not names:
        raise ValueError("the table has no value channel to store in a texture")
    if len(names) > 4:
        raise ValueError(f"a texture holds at most 4 channels, the table has {len(names)}: {', '.join(names)}")
    return np.stack([stored[n] for n in names], axis=-1)


def _uniform(values: np.ndarray) -> bool:
    if values.size < 2:
        return False
    steps = np.diff(values)
    return bool(np.all(np.abs(steps - steps[0]) <= 1e-9 * max(1.0, float(np.max(np.abs(values))))))


def _lit(x) -> str:
    """A plain decimal literal of ``x`` (``repr`` of a Python float: exact, no ``np.float64(...)``),
    valid in Python, GLSL, HLSL, WGSL and C."""
    return repr(float(x))


def _index_words(name: str) -> str:
    return f"the fractional index of {name} in the axis values (bsdf_tab_axes)"


def _axis_entry(name: str, values: np.ndarray, t: str) -> tuple[dict, str | None]:
    """(entry without "coordinate", the normalized position (a - a_0) / (a_last - a_0) as an
    expression, None for unequal steps or a single node)."""
    n = values.size
    entry = {"name": name, "texture_axis": t, "size": n, "first": float(values[0]), "last": float(values[-1])}
    if n == 1:
        entry["mapping"] = "single node"
        return entry, None
    if _uniform(values):
        entry["mapping"] = "equal steps"
        return entry, f"({name} - {_lit(values[0])}) / ({_lit(values[-1])} - {_lit(values[0])})"
    entry["mapping"] = "unequal steps"
    return entry, None


def lookup_convention(axes: dict, names: list[str], layout: str = "volume") -> dict:
    """How to sample the texture: texture axis per table axis, the coordinate of a value, channels.

    Parameters
    ----------
    axes : dict
        Axis name -> values, in axis order (1 to 3 axes).
    names : list of str
        The stored channels, in component order.
    layout : str
        ``"volume"`` (KTX2, DDS: a 3-D table is a 3-D texture, w = axis 0) or ``"stacked"``
        (PNG: the axis-0 slices of a 3-D table stacked vertically in one 2-D image, row =
        i0 * n1 + i1). 1-D and 2-D tables are laid out alike in both.

    Returns
    -------
    dict
        ``{"layout": {"kind", "width", "height", "depth", "texel", ...}, "texel_centres": ...,
        "axes": [{"name", "texture_axis", "size", "first", "last", "mapping", "coordinate"}],
        "components": {"R": channel, ...}}``. Every number in a ``coordinate`` is a plain
        decimal literal, so the right-hand side evaluates as written (Python, GLSL, HLSL) with
        the axis value bound to the axis name (and, stacked, ``i_<axis 0>`` to the slice index).
    """
    if layout not in ("volume", "stacked"):
        raise ValueError(f"unknown texture layout {layout!r}; 'volume' or 'stacked'")
    items = [(name, np.asarray(v, dtype=np.float64)) for name, v in axes.items()]
    sizes = [v.size for _, v in items]
    stacked = layout == "stacked" and len(items) == 3
    out = []
    if stacked:
        (n0name, a0), (n1name, a1), (n2name, a2) = items
        n0, n1, n2 = sizes
        height = n0 * n1
        slice_var = f"i_{n0name}"
        e0, pos0 = _axis_entry(n0name, a0, "slice")
        if n0 == 1:
            e0["coordinate"] = "slice = 0.0"
        elif pos0 is not None:
            e0["coordinate"] = f"slice = {pos0} * {_lit(n0 - 1)}"
        else:
            e0["coordinate"] = f"slice = k, k {_index_words(n0name)}"
        e0["coordinate_note"] = (f"the fractional slice index s in [0, {n0 - 1}]; not a texture axis: sample "
                                 f"slices {slice_var} = floor(s) and min(floor(s) + 1, {n0 - 1}) (v below) and mix "
                                 "the two samples by s - floor(s)")
        e1, pos1 = _axis_entry(n1name, a1, "v")
        if n1 == 1:
            e1["coordinate"] = f"v = ({slice_var} * {_lit(n1)} + 0.5) / {_lit(height)}"
        elif pos1 is not None:
            e1["coordinate"] = (f"v = ({slice_var} * {_lit(n1)} + {pos1} * {_lit(n1 - 1)} + 0.5) / {_lit(height)}")
        else:
            e1["coordinate"] = (f"v = ({slice_var} * {_lit(n1)} + k + 0.5) / {_lit(height)}, k "
                                f"{_index_words(n1name)}")
        e1["coordinate_note"] = (f"{slice_var} is the integer slice index (node index of {n0name}); for "
                                 f"{n1name} within [first, last] v stays between the centres of the slice's "
                                 f"first and last rows, so linear filtering never mixes two slices")
        out = [e0, e1, _finish_entry(*_axis_entry(n2name, a2, "u"))]
        layout_info = {
            "kind": "stacked slices",
            "width": n2,
            "height": height,
            "depth": 0,
            "texel": (f"texel (x, y) = node (i_{n2name}, i_{n1name}, i_{n0name}) at x = i_{n2name}, "
                      f"y = i_{n0name} * {n1} + i_{n1name}: rows i * {n1} .. i * {n1} + {n1 - 1} hold slice i "
                      f"of {n0name}, row 0 first in memory"),
            "filtering": (f"linear filtering along u and v stays inside a slice as long as v is within the centres "
                          f"of that slice's rows (what the v coordinate gives); never filter across a slice "
                          f"boundary: interpolate along {n0name} with two samples (see its coordinate)"),
        }
        centres = (f"node i of an axis of n nodes is the centre of texel i; u = (i_{n2name} + 0.5) / {n2}, "
                   f"v = (i_{n0name} * {n1} + i_{n1name} + 0.5) / {height}; row 0 (v = 0) first in memory")
    else:
        tex_axes = {1: ["u"], 2: ["v", "u"], 3: ["w", "v", "u"]}[len(items)]
        for (name, values), t in zip(items, tex_axes):
            out.append(_finish_entry(*_axis_entry(name, values, t)))
        rev = list(reversed(items))
        dims = dict(zip(("width", "height", "depth"), reversed(sizes)))
        coords = {1: "x", 2: "(x, y)", 3: "(x, y, z)"}[len(items)]
        node = ", ".join(f"i_{n}" for n, _ in rev)
        node = node if len(items) == 1 else f"({node})"
        one_row = 1 if layout == "stacked" else 0  # a PNG is always a 2-D image
        layout_info = {
            "kind": {1: "1d", 2: "2d", 3: "volume"}[len(items)],
            "width": dims["width"],
            "height": dims.get("height", one_row),
            "depth": dims.get("depth", 0),
            "texel": f"texel {coords} = node {node}" + ("; slice z = 0 first in memory, row y = 0 first in "
                                                          "each slice" if len(items) == 3 else
                                                          "; row y = 0 first in memory" if len(items) == 2 else ""),
        }
        centres = ("node i of an axis of n nodes is the centre of texel i, coordinate (i + 0.5) / n; "
                   "row 0 (v = 0) first in memory; linear filtering interpolates between nodes")
    return {
        "layout": layout_info,
        "texel_centres": centres,
        "axes": out,
        "components": {COMPONENTS[k]: n for k, n in enumerate(names)},
    }


def _finish_entry(entry: dict, pos: str | None) -> dict:
    """An axis that is a texture axis of its own: node i at (i + 0.5) / n."""
    t, n, name = entry["texture_axis"], entry["size"], entry["name"]
    if n == 1:
        entry["coordinate"] = f"{t} = 0.5"
    elif pos is not None:
        entry["coordinate"] = f"{t} = {pos} * {_lit(n - 1)} / {_lit(n)} + 0.5 / {_lit(n)}"
    else:
        entry["coordinate"] = f"{t} = (k + 0.5) / {_lit(n)}, k {_index_words(name)}"
    return entry


def metadata_strings(axes: dict, names: list[str], meta: dict, layout: str = "volume") -> dict[str, str]:
    """``bsdf_tab_*`` key -> JSON string: spec, axes (full precision), stored channels ``names``,
    the lookup convention (for ``layout``, see :func:`lookup_convention`), meta."""
    meta = meta if isinstance(meta, dict) else {}
    return {
        "bsdf_tab_axes": json.dumps({n: np.asarray(a, dtype=np.float64).tolist() for n, a in axes.items()}),
        "bsdf_tab_channels": json.dumps(list(names)),
        "bsdf_tab_lookup": json.dumps(lookup_convention(axes, list(names), layout)),
        "bsdf_tab_meta": json.dumps(meta, default=json_default),
        "bsdf_tab_spec": json.dumps(meta.get("spec"), default=json_default),
        "bsdf_tab_version": str(meta.get("version", "")),
    }


def parts_from_metadata(strings: dict[str, str], source: str) -> tuple[dict, list[str], dict]:
    """(axes, channel names, meta) from the strings :func:`metadata_strings` wrote.

    Raises
    ------
    ValueError
        If a key is missing or is not JSON.
    """
    try:
        axes = {n: np.asarray(v, dtype=np.float64) for n, v in json.loads(strings["bsdf_tab_axes"]).items()}
        names = list(json.loads(strings["bsdf_tab_channels"]))
        meta = json.loads(strings["bsdf_tab_meta"])
    except KeyError as exc:
        raise ValueError(f"{source}: not a bsdf-tab texture (no {exc.args[0]} metadata)") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{source}: bad bsdf-tab metadata ({exc})") from None
    return axes, names, meta


def table_from_texels(texels: np.ndarray, axes: dict, names: list[str], meta: dict) -> tuple[dict, dict]:
    """(channels, meta) of a table read back: the decoded components as value channels.

    The texture holds no error channels: for each channel ``X`` the read-back table gets
    ``X_err`` filled with the stored bound ``meta["storage"]["channels"][X]["total_error"]`` when
    the metadata has it (the max over texels, so an upper bound everywhere).
    """
    shape = tuple(len(a) for a in axes.values())
    channels = {n: np.ascontiguousarray(texels[..., k].reshape(shape)) for k, n in enumerate(names)}
    storage = meta.get("storage", {}) if isinstance(meta, dict) else {}
    per_channel = storage.get("channels", {}) if isinstance(storage, dict) else {}
    for n in names:
        bound = per_channel.get(n, {}).get("total_error") if isinstance(per_channel.get(n), dict) else None
        if bound is not None:
            channels[n + ERR_SUFFIX] = np.full(shape, float(bound))
    return channels, meta
