"""Preview images: a heatmap PNG of one channel of a table (matplotlib, Agg backend).

- 2-D tables: the channel over (first axis on x, second axis on y), with a colour bar.
- 3-D tables: one slice; ``slice_axis`` (default: the last axis) is held at index ``slice``
  (default: the middle), the other two axes are plotted as for 2-D.
- 1-D tables: a line plot of the channel over its axis.

Axes with non-uniform values are drawn at their true positions (``pcolormesh`` on cell edges
half-way between nodes), so a ``square``-spaced axis looks right.

Uses the object-oriented API (``Figure`` + ``FigureCanvasAgg``), never ``pyplot``, so renders
in worker threads do not share global state.
"""

from __future__ import annotations

import io
import re

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from bsdf_tab.table import Table

from .errors import ServiceError

__all__ = ["PreviewParams", "check_preview", "render_png"]

_INDEX_RE = re.compile(r"^-?[0-9]{1,9}$")

_LABELS = {
    "mu": "mu = cos(theta_i)",
    "alpha": "alpha (GGX/Beckmann width)",
    "roughness": "roughness (alpha = roughness^2)",
    "eta": "eta = eta_o / eta_i",
    "theta_i": "theta_i (rad)",
    "theta_o": "theta_o (rad)",
    "theta_h": "theta_h (rad)",
    "theta_d": "theta_d (rad)",
    "phi_d": "phi_d (rad)",
}


class PreviewParams(tuple):
    """(channel, slice_axis, slice_index): validated, normalized preview parameters."""

    __slots__ = ()

    def __new__(cls, channel: str, slice_axis: str | None, index: int | None):
        return super().__new__(cls, (channel, slice_axis, index))

    @property
    def variant(self) -> str:
        channel, axis, index = self
        return f"png-{channel}" + (f"-{axis}{index}" if axis is not None else "")


def _bad(param: str, message: str, allowed=None) -> ServiceError:
    return ServiceError(400, "invalid_parameter", message, param=param, allowed=allowed, query_param=param)


def check_preview(axes: dict, channels: list[str], channel: str | None, slice_axis: str | None, index: str | None) -> PreviewParams:
    """Validate the preview query parameters against the table's axes and channels."""
    if channel is None:
        channel = channels[0]
    if channel not in channels:
        raise _bad("channel", f"unknown channel {channel[:40]!r}", allowed=channels)
    names = list(axes)
    if len(names) < 3:
        if slice_axis is not None or index is not None:
            raise _bad("slice" if index is not None else "slice_axis", f"only 3-D tables are sliced; this one has axes {names}")
        return PreviewParams(channel, None, None)
    if slice_axis is None:
        slice_axis = names[-1]
    if slice_axis not in names:
        raise _bad("slice_axis", f"unknown axis {slice_axis[:40]!r}", allowed=names)
    n = len(axes[slice_axis])
    if index is None:
        i = n // 2
    else:
        t = index.strip()
        if not _INDEX_RE.match(t):  # ASCII digits only: "--1" or "²" would reach int() and fail there
            raise _bad("slice", f"must be an integer index, got {index[:40]!r}")
        i = int(t)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise _bad("slice", f"must be in [0, {n - 1}] (index into {slice_axis}), got {index}", allowed=[0, n - 1])
    return PreviewParams(channel, slice_axis, i)


def _edges(x: np.ndarray) -> np.ndarray:
    """Cell edges around nodes ``x`` (half-way between nodes; unit cell for one node)."""
    x = np.asarray(x, dtype=np.float64)
    if x.size == 1:
        return np.array([x[0] - 0.5, x[0] + 0.5]) if x[0] == 0 else np.array([x[0] * 0.95, x[0] * 1.05])
    mid = 0.5 * (x[1:] + x[:-1])
    return np.concatenate([[x[0] - (mid[0] - x[0])], mid, [x[-1] + (x[-1] - mid[-1])]])


def _label(name: str) -> str:
    return _LABELS.get(name, name)


def render_png(table: Table, params: PreviewParams) -> bytes:
    """The preview PNG of ``table`` (see the module docstring)."""
    channel, slice_axis, index = params
    values = np.asarray(table.channels[channel], dtype=np.float64)
    names = list(table.axes)
    spec = table.meta.get("spec", {}) if isinstance(table.meta, dict) else {}
    title = f"{table.kind or 'table'} {channel}"
    dist = spec.get("distribution")
    if dist:
        title += f"  ({dist}, {spec.get('shadowing', '')})"
    fig = Figure(figsize=(6.4, 4.8), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    if len(names) == 1:
        x = table.axes[names[0]]
        ax.plot(x, values, marker="." if x.size <= 64 else None)
        ax.set_xlabel(_label(names[0]))
        ax.set_ylabel(channel)
        ax.grid(True, alpha=0.3)
    else:
        if len(names) == 3:
            k = names.index(slice_axis)
            values = np.take(values, index, axis=k)
            names = [n for n in names if n != slice_axis]
            title += f"\n{slice_axis} = {table.axes[slice_axis][index]:.4g} (index {index})"
        elif len(names) > 3:  # pragma: no cover - no such table kind yet
            values = values.reshape(values.shape[0], values.shape[1], -1)[:, :, 0]
            names = names[:2]
        xa, ya = table.axes[names[0]], table.axes[names[1]]
        masked = np.ma.masked_invalid(values.T)  # rows = y (second axis), columns = x (first axis)
        mesh = ax.pcolormesh(_edges(xa), _edges(ya), masked, cmap="viridis", shading="flat")
        cbar = fig.colorbar(mesh, ax=ax)
        cbar.set_label(channel)
        ax.set_xlabel(_label(names[0]))
        ax.set_ylabel(_label(names[1]))
    ax.set_title(title, fontsize=10)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()
