"""Preview images: a heatmap PNG of one channel of a table (matplotlib, Agg backend).

- 2-D tables: the channel over (first axis on x, second axis on y), with a colour bar.
- 3-D and 4-D tables: one slice; the held axes (``slice_axis``, default: all but the first two)
  are each at one index (``slice``: an integer for one held axis, or ``axis=i`` pairs; default:
  the middle of each); the two shown axes are plotted as for 2-D, and the title says which slice.
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

from bsdf_tab.table import Table

from .errors import ServiceError

__all__ = ["PreviewParams", "check_preview", "preview_slice", "render_png", "draw_png"]

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
    "phi_v": "phi_v (rad, view azimuth from the tangent)",
    "anisotropy": "anisotropy a (alpha_x / alpha_y = 1 / (1 - 0.9 a))",
}


class PreviewParams(tuple):
    """(channel, held): the channel and the ((axis, index), ...) held fixed, in table axis order."""

    __slots__ = ()

    def __new__(cls, channel: str, held: tuple[tuple[str, int], ...] = ()):
        return super().__new__(cls, (channel, tuple(held)))

    @property
    def channel(self) -> str:
        return self[0]

    @property
    def held(self) -> tuple[tuple[str, int], ...]:
        return self[1]

    @property
    def variant(self) -> str:
        return f"png-{self.channel}" + "".join(f"-{axis}{index}" for axis, index in self.held)


def _bad(param: str, message: str, allowed=None) -> ServiceError:
    return ServiceError(400, "invalid_parameter", message, param=param, allowed=allowed, query_param=param)


def _index(text: str, axis: str, n: int) -> int:
    t = text.strip()
    if not _INDEX_RE.match(t):  # ASCII digits only: "--1" or "²" would reach int() and fail there
        raise _bad("slice", f"must be an integer index, got {text[:40]!r}")
    i = int(t)
    if i < 0:
        i += n
    if not 0 <= i < n:
        raise _bad("slice", f"must be in [0, {n - 1}] (index into {axis}), got {text[:40]}", allowed=[0, n - 1])
    return i


def _names(text: str, names: list[str], param: str) -> list[str]:
    out = []
    for part in text.split(","):
        name = part.strip()
        if name not in names:
            raise _bad(param, f"unknown axis {name[:40]!r}", allowed=names)
        if name in out:
            raise _bad(param, f"axis {name!r} given twice")
        out.append(name)
    return out


def check_preview(axes: dict, channels: list[str], channel: str | None, slice_axis: str | None, index: str | None) -> PreviewParams:
    """Validate the preview query parameters against the table's axes and channels.

    A table of N > 2 axes shows two of them; the other N - 2 are *held* at one index each:
    ``slice_axis`` names the held axes (comma-separated; default: the last N - 2), ``slice`` gives
    their indices, either one integer (one held axis: a 3-D table) or ``axis=i`` pairs
    (``alpha=3,anisotropy=2``; an axis named there is held even without ``slice_axis``); an axis
    held without an index is at its middle, ``n // 2``. Negative indices count from the end.
    """
    if channel is None:
        channel = channels[0]
    if channel not in channels:
        raise _bad("channel", f"unknown channel {channel[:40]!r}", allowed=channels)
    names = list(axes)
    n_held = max(len(names) - 2, 0)
    if n_held == 0:
        if slice_axis is not None or index is not None:
            raise _bad("slice" if index is not None else "slice_axis",
                       f"only tables of 3 or more axes are sliced; this one has axes {names}")
        return PreviewParams(channel)
    pairs: dict[str, str] = {}
    single = None
    if index is not None and "=" in index:
        for part in index.split(","):
            name, _, value = part.partition("=")
            (name,) = _names(name, names, "slice")
            if name in pairs:
                raise _bad("slice", f"axis {name!r} given twice")
            pairs[name] = value
    elif index is not None:
        single = index
    if slice_axis is not None:
        held = _names(slice_axis, names, "slice_axis")
        if len(held) != n_held:
            raise _bad("slice_axis", f"name {n_held} held axis (axes {names}: two are shown), got {len(held)}")
        for name in pairs:
            if name not in held:
                raise _bad("slice", f"axis {name!r} is shown, not held (slice_axis={','.join(held)})", allowed=held)
    else:
        if len(pairs) > n_held:
            raise _bad("slice", f"at most {n_held} held axes (axes {names}: two are shown), got {len(pairs)}")
        held = list(pairs)
        for name in reversed(names):  # the rest from the last axes
            if len(held) >= n_held:
                break
            if name not in held:
                held.append(name)
    if single is not None and len(held) != 1:
        raise _bad("slice", f"this table holds {len(held)} axes ({', '.join(held)}): give slice="
                   + ",".join(f"{h}=i" for h in held))
    out = []
    for name in names:  # table order
        if name not in held:
            continue
        n = len(axes[name])
        text = single if single is not None else pairs.get(name)
        out.append((name, n // 2 if text is None else _index(text, name, n)))
    return PreviewParams(channel, tuple(out))


def preview_slice(table: Table, params: PreviewParams) -> tuple[list[str], np.ndarray, str]:
    """(shown axis names, the channel's values over them, the slice's caption) of a preview."""
    values = np.asarray(table.channels[params.channel], dtype=np.float64)
    names = list(table.axes)
    index = tuple(dict(params.held).get(n, slice(None)) for n in names)
    shown = [n for n in names if n not in dict(params.held)]
    caption = ", ".join(f"{a} = {float(table.axes[a][i]):.4g} (index {i} of {len(table.axes[a])})" for a, i in params.held)
    return shown, values[index], caption


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
    spec = table.meta.get("spec", {}) if isinstance(table.meta, dict) else {}
    title = f"{table.kind or 'table'} {params.channel}"
    dist = spec.get("distribution")
    if dist:
        title += f"  ({dist}, {spec.get('shadowing', '')})"
    shown, values, caption = preview_slice(table, params)
    if caption:
        title += f"\n{caption}"
    return draw_png([table.axes[n] for n in shown], shown, values, params.channel, title)


def draw_png(coords: list[np.ndarray], names: list[str], values: np.ndarray, channel: str, title: str) -> bytes:
    """A line plot (one axis) or heatmap (two axes: first on x, second on y) of ``values``."""
    # matplotlib (about 1 s to import) loads with the first preview, not at the service's start
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.8), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    if len(names) == 1:
        x = coords[0]
        ax.plot(x, values, marker="." if x.size <= 64 else None)
        ax.set_xlabel(_label(names[0]))
        ax.set_ylabel(channel)
        ax.grid(True, alpha=0.3)
    else:
        xa, ya = coords
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
