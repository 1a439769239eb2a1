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
with equal steps; otherwise the fractional index in the stored axis values).
"""

from __future__ import annotations

import json

import numpy as np

from .base import ERR_SUFFIX, json_default, shape_of, value_channels

__all__ = [
    "COMPONENTS",
    "image_dims",
    "lookup_convention",
    "metadata_strings",
    "parts_from_metadata",
    "texel_array",
    "table_from_texels",
]

#: Component letters, in order.
COMPONENTS = "RGBA"


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


def lookup_convention(axes: dict, names: list[str]) -> dict:
    """How to sample the texture: texture axis per table axis, the coordinate of a value, channels.

    Returns
    -------
    dict
        ``{"texel_centres": ..., "axes": [{"name", "texture_axis", "size", "first", "last",
        "mapping", "coordinate"}], "components": {"R": channel, ...}}``.
    """
    tex_axes = {1: ["u"], 2: ["v", "u"], 3: ["w", "v", "u"]}[len(axes)]
    out = []
    for (name, values), t in zip(axes.items(), tex_axes):
        values = np.asarray(values, dtype=np.float64)
        n = values.size
        entry = {"name": name, "texture_axis": t, "size": n, "first": float(values[0]), "last": float(values[-1])}
        if n == 1:
            entry["mapping"] = "single node"
            entry["coordinate"] = f"{t} = 0.5"
        elif _uniform(values):
            entry["mapping"] = "equal steps"
            entry["coordinate"] = (f"{t} = ({name} - {values[0]!r}) / ({values[-1]!r} - {values[0]!r}) "
                                   f"* {n - 1} / {n} + 0.5 / {n}")
        else:
            entry["mapping"] = "unequal steps"
            entry["coordinate"] = (f"{t} = (k + 0.5) / {n}, k the fractional index of {name} in the "
                                   f"axis values (bsdf_tab_axes)")
        out.append(entry)
    return {
        "texel_centres": "node i of an axis of n nodes is the centre of texel i, coordinate (i + 0.5) / n; "
        "row 0 (v = 0) first in memory; linear filtering interpolates between nodes",
        "axes": out,
        "components": {COMPONENTS[k]: n for k, n in enumerate(names)},
    }


def metadata_strings(axes: dict, names: list[str], meta: dict) -> dict[str, str]:
    """``bsdf_tab_*`` key -> JSON string: spec, axes (full precision), stored channels ``names``,
    the lookup convention, meta."""
    meta = meta if isinstance(meta, dict) else {}
    return {
        "bsdf_tab_axes": json.dumps({n: np.asarray(a, dtype=np.float64).tolist() for n, a in axes.items()}),
        "bsdf_tab_channels": json.dumps(list(names)),
        "bsdf_tab_lookup": json.dumps(lookup_convention(axes, list(names))),
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
