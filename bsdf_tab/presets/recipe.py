"""What a preset is: declarative data that says how a peer's table follows from one spec.

A :class:`Preset` names the peer's axes (in the peer's order), one source table (kind,
shadowing, Fresnel) whose axes are taken from the peer's (:attr:`Preset.spec_axes`: spec axis
-> peer axis, optionally through ``1/x``), the peer's channels as sums of source channels or
their complements (:class:`Output`), and the peer's rules (Cycles' mirror rule, the clamp to
[0, 1]). :func:`bsdf_tab.presets.build_preset` runs it; error channels follow the
transformations (absolute errors add; a rule adds what it changed).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

__all__ = ["Output", "Preset"]


@dataclass(frozen=True)
class Output:
    """A peer channel: ``terms`` summed (source channels), or ``1 -`` that sum, times ``scale``.

    ``scale(axes) -> array``, when given, multiplies the channel and its error after the
    channel is in the peer's axis order: ``axes`` is the output's (possibly selected) axes in
    that order, and the array must broadcast to the channel's shape (EEVEE's BTDF texture holds
    T / (1 - F0(ior)), which its shader multiplies by 1 - F0).
    """

    name: str
    terms: tuple[str, ...]
    complement: bool = False
    scale: Callable[[dict], np.ndarray] | None = None


@dataclass(frozen=True)
class Preset:
    """One peer table.

    Attributes
    ----------
    name : str
        Registry name (``cycles-ggx-E``).
    peer : str
        The engine and the table's name there.
    description : str
        One line.
    axes : callable
        ``axes() -> dict`` of the full output axes, in the peer's order (name -> values).
    table, shadowing, fresnel : str, str, str or None
        The source spec: table kind, shadowing mode and Fresnel type (GGX throughout).
    spec_axes : dict
        Spec axis name -> peer axis name, or ``("1/", peer axis)`` for the reciprocal.
    outputs : tuple of Output
        The peer's channels, in order.
    mirror_rule : bool
        Cycles' rule: alpha = roughness^2 with alpha^2 <= 5e-7 is a perfect mirror (value 1).
    clamp01 : bool
        Clamp the values to [0, 1] (after the mirror rule).
    conventions : dict
        What is reproduced and what is not (recorded in ``meta["preset"]``).
    anchor : str or None
        ``<folder>/<file>.npy`` of the peer's own table in the anchors folder, if shipped there.
    anchor_axes : dict
        Output axis name -> anchor axis file, for checking axes against the peer's.
    file_format : str or None
        The registry format the engine loads (``ktx2``, ``dds``, ``png``); ``bake --preset``
        writes it unless ``--format`` says otherwise (None: ``exr``).
    storage : str or None
        The engine's storage encoding (:data:`bsdf_tab.io.storage.ENCODINGS`: ``float16``,
        ``unorm16``, ...), used by the texture formats unless ``--precision`` says otherwise.
    options : dict
        The kind's own spec keys (``bsdf_tab.spec.KIND_OPTIONS``: ``amplitude`` of ``ltc``,
        ``sheen_shadowing`` of ``sheen_albedo``), added to the source spec as they are.
    """

    name: str
    peer: str
    description: str
    axes: Callable[[], dict]
    table: str
    shadowing: str
    spec_axes: dict
    outputs: tuple[Output, ...]
    conventions: dict
    fresnel: str | None = None
    mirror_rule: bool = False
    clamp01: bool = False
    anchor: str | None = None
    anchor_axes: dict = field(default_factory=dict)
    file_format: str | None = None
    storage: str | None = None
    options: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self.axes().values())

    def spec(self, axes: dict) -> dict:
        """The source spec on the peer axes ``axes`` (explicit value lists, maybe unsorted)."""
        spec_axes = {}
        for name, source in self.spec_axes.items():
            if isinstance(source, tuple):  # ("1/", peer axis)
                spec_axes[name] = 1.0 / np.asarray(axes[source[1]], dtype=np.float64)
            else:
                spec_axes[name] = np.asarray(axes[source], dtype=np.float64)
        spec = {"table": self.table, "distribution": "ggx", "shadowing": self.shadowing, "axes": spec_axes}
        if self.fresnel is not None:
            spec["fresnel"] = {"type": self.fresnel}
        spec.update(self.options)
        return spec

    def peer_axis_of(self, spec_axis: str) -> str:
        """The peer axis a spec axis is taken from."""
        source = self.spec_axes[spec_axis]
        return source[1] if isinstance(source, tuple) else source
