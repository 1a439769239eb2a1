"""Running a preset: its source spec through :func:`bsdf_tab.api.tabulate`, then the peer's rules."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..api import tabulate
from ..spec import normalize_spec
from ..table import Table
from .engines import GROUPS, PRESETS
from .recipe import Preset

__all__ = ["CYCLES_MIRROR_ALPHA2", "PresetJob", "build_preset", "prepare_preset", "describe", "expand_preset", "get_preset", "preset_names"]

CYCLES_MIRROR_ALPHA2 = 5e-7  # Cycles: alpha_x * alpha_y <= 5e-7 is a perfect mirror (E = 1)


def preset_names() -> list[str]:
    """Names of all presets, in registry order."""
    return list(PRESETS)


def get_preset(name: str) -> Preset:
    """The preset ``name``; ValueError (one line, with the choices) if unknown."""
    if name not in PRESETS:
        raise ValueError(
            f"unknown preset {name!r}; choose one of: {', '.join(PRESETS)} (or a group: {', '.join(GROUPS)})"
        )
    return PRESETS[name]


def expand_preset(name: str) -> list[str]:
    """A preset or group name -> the preset names it stands for."""
    if name in GROUPS:
        return list(GROUPS[name])
    return [get_preset(name).name]


def describe(preset: Preset) -> str:
    """One line: name, shape and description."""
    shape = " x ".join(f"{n} {len(v)}" for n, v in preset.axes().items())
    return f"{preset.name:<31} {shape:<30} {preset.description}"


def _select(axes: dict, select: dict | None) -> dict:
    if not select:
        return dict(axes)
    unknown = set(select) - set(axes)
    if unknown:
        raise ValueError(f"select: unknown axis {sorted(unknown)[0]!r}; axes are {', '.join(axes)}")
    return {n: (v[np.asarray(select[n], dtype=int)] if n in select else v) for n, v in axes.items()}


@dataclass(frozen=True)
class PresetJob:
    """A preset made ready to compute: the spec to tabulate, and :meth:`finish` to turn that
    table into the peer's (the CLI submits many presets' specs to a cluster at once)."""

    preset: Preset
    axes: dict
    select: dict | None
    spec: dict  # normalized, on the sorted distinct values of each peer axis
    inverse: dict  # axis name -> indices back to the peer's (maybe unsorted, repeated) values

    def finish(self, source_table: Table) -> Table:
        """The peer's table from the tabulated ``spec``."""
        index = np.ix_(*[self.inverse[n] for n in self.spec["axes"]])
        source = {k: np.asarray(v, dtype=np.float64)[index] for k, v in source_table.channels.items()}
        return _peer_table(self, source, source_table.meta)


def prepare_preset(name: str, select: dict | None = None) -> PresetJob:
    """The :class:`PresetJob` of preset ``name`` (optionally on a subset of its axes).

    A spec's axes increase strictly, the peers' need not (OpenPBR has ior = 1 twice, reversed
    eta = 1/ior): the spec takes the sorted distinct values and :meth:`PresetJob.finish`
    indexes back.
    """
    preset = get_preset(name)
    axes = _select(preset.axes(), select)
    spec = preset.spec(axes)
    uniq, inverse = {}, {}
    for axis, values in spec["axes"].items():
        uniq[axis], inverse[axis] = np.unique(np.asarray(values, dtype=np.float64), return_inverse=True)
    nspec = normalize_spec({**spec, "axes": {n: [float(x) for x in v] for n, v in uniq.items()}})
    return PresetJob(preset, axes, select, nspec, inverse)


def _mirror_rule(values: np.ndarray, errors: np.ndarray, alpha: np.ndarray, axis: int):
    """Cycles' rule: alpha^2 <= 5e-7 is a perfect mirror, E = 1 (error grows by the change)."""
    shape = [1] * values.ndim
    shape[axis] = alpha.size
    mirror = (alpha**2 <= CYCLES_MIRROR_ALPHA2).reshape(shape)
    new = np.where(mirror, 1.0, values)
    return new, errors + np.abs(new - values)


def _clamp01(values: np.ndarray, errors: np.ndarray):
    new = np.clip(values, 0.0, 1.0)
    return new, errors + np.abs(new - values)


def _peer_channels(preset: Preset, axes: dict, source: dict, spec_axis_names: list[str]) -> dict:
    """The peer's channels (values, then ``_err``) on ``axes`` from the source channels."""
    perm = [spec_axis_names.index(next(s for s in preset.spec_axes if preset.peer_axis_of(s) == name))
            for name in axes]
    values, errors = {}, {}
    for out in preset.outputs:
        v = source[out.terms[0]]
        e = source[out.terms[0] + "_err"]
        for term in out.terms[1:]:
            v = v + source[term]
            e = e + source[term + "_err"]
        v, e = np.transpose(v, perm), np.transpose(e, perm)
        if out.complement:
            v = 1.0 - v
        if out.scale is not None:
            s = np.asarray(out.scale(axes), dtype=np.float64)
            v, e = v * s, e * np.abs(s)
        if preset.mirror_rule:
            rough = list(axes).index("roughness")
            v, e = _mirror_rule(v, e, np.asarray(axes["roughness"]) ** 2, rough)
        if preset.clamp01:
            v, e = _clamp01(v, e)
        values[out.name], errors[out.name + "_err"] = v, e
    return {**values, **errors}


def build_preset(
    name: str,
    *,
    select: dict | None = None,
    device: str | None = None,
    workers: int | None = None,
    progress: bool | Callable[[int, int], None] = False,
    scheduler=None,
) -> Table:
    """Compute the preset ``name`` in its peer's layout.

    Parameters
    ----------
    name : str
        A preset name (see :func:`preset_names`).
    select : dict, optional
        Output axis name -> indices into the full peer axis: compute only that subset
        (the values are the peer's; used by tests and quick looks).
    device, workers, progress, scheduler :
        Passed to :func:`bsdf_tab.tabulate`.

    Returns
    -------
    Table
        Axes in the peer's order, the peer's channels plus ``_err`` channels, and
        ``meta["preset"]`` with the conventions and the source spec.
    """
    job = prepare_preset(name, select)
    return job.finish(tabulate(job.spec, device=device, workers=workers, progress=progress, scheduler=scheduler))


def _peer_table(job: PresetJob, source: dict, source_meta: dict) -> Table:
    preset, axes, select, nspec = job.preset, job.axes, job.select, job.spec
    table = Table(axes, _peer_channels(preset, axes, source, list(nspec["axes"])), {})
    table.meta = {
        "table": preset.name,
        "spec": {"table": f"preset:{preset.name}", "preset": preset.name, "sources": [nspec]},
        "preset": {
            "name": preset.name,
            "peer": preset.peer,
            "description": preset.description,
            "conventions": preset.conventions,
            "axis_order": list(axes),
            "full_shape": list(preset.shape),
            "subset": {k: [int(i) for i in v] for k, v in (select or {}).items()},
            "notes": [],
        },
        "conventions": preset.conventions,
        "method": source_meta.get("method"),
        "max_error": table.max_error(),
        "version": source_meta.get("version"),
    }
    return table
