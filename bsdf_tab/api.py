"""The only way to compute a table: :func:`tabulate` (whole tables) and :func:`iter_blocks`
(tables too large to hold, in blocks of axis-0 slices).

Both go spec -> :func:`bsdf_tab.spec.normalize_spec` -> the table registry
(:mod:`bsdf_tab.tables`) -> the integrators and kernels, and record the same metadata
(:func:`table_meta`). The CLI, the presets, the scene planner, the service and the benchmarks
all call these two functions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from .errors import NonFiniteTableError
from .integrate.runtime import resolve_device
from .spec import normalize_spec, resolve_axes
from .table import Table
from .tables import KINDS, Context
from .version import __version__

__all__ = ["BlockStream", "METHOD_TEXT", "check_finite", "conventions", "iter_blocks", "quiet_warp", "streams",
           "table_meta", "tabulate", "tabulate_many"]

ProgressArg = bool | Callable[[int, int], None]
#: A ``distributed.Client``, a scheduler address (``tcp://host:8786``) or ``"local:N"``.
Scheduler = object

_SHADOWING_TEXT = {
    "separable": "separable G = G1(i) G1(o) (Walter 2007)",
    "correlated": "height-correlated G = 1 / (1 + Lambda(i) + Lambda(o)) (Heitz 2014)",
}
#: Method name -> the description recorded in every table's metadata.
METHOD_TEXT = {
    "adaptive": "nested adaptive Gauss-Kronrod (G7-K15, staged: G7 first where its estimate "
    "allows) over micro-normal space, theta_m outer and phi inner, split at the closed-form "
    "horizon, i.m = 0, critical-angle and transmission-horizon curves; error = sum over accepted "
    "outer intervals of their estimates (QUADPACK's rescaled |K15 - G7| with a Legendre-tail "
    "floor, or a safety factor on the staged rules' differences) plus twice the inner estimates "
    "plus a rigorous mass bound of any D tail left out (docs/methods.md)",
    "point": "float64 point evaluation of the BSDF (Walter eqs. 20 and 21); error = rounding bound",
    "gauss_kronrod": "G7-K15 over the half vector, split at the closed-form horizon; error = sum of |K15 - G7| "
    "(the sheen tables' own kernel, bsdf_tab/tables/sheen.py)",
}

#: Table kinds whose lobe is not the spec's microfacet distribution: what their metadata records.
_SHEEN_SHADOWING = {
    "fitted": "Estevez and Kulla 2017 fitted Lambda (glTF KHR_materials_sheen, Filament), V clamped to [0, 1]",
    "exact": "exact Smith Lambda of the Charlie distribution, computed numerically",
    "ashikhmin": "Ashikhmin / Neubelt visibility 1 / (4 (mu_i + mu_o - mu_i mu_o)) (Filament's cloth)",
}


def quiet_warp() -> None:
    """Keep Warp's start-up and module-load messages off stdout (the CLI and the service call it)."""
    import warp

    warp.config.log_level = getattr(warp, "LOG_WARNING", 30)  # Warp >= 1.1x: logging threshold
    warp.config.quiet = True  # older Warp releases


def conventions(nspec: dict) -> dict:
    """Human- and machine-readable conventions recorded in every table's metadata."""
    rough = "roughness" if "roughness" in nspec["axes"] or "roughness" in nspec else "alpha"
    if nspec["table"] == "bsdf":
        alpha_text = f"scalar material alpha = {nspec.get('alpha')}"
        if "roughness" in nspec:
            alpha_text = f"scalar material roughness = {nspec['roughness']} (alpha = roughness^2)"
    elif rough == "roughness":
        alpha_text = "alpha = roughness^2"
    else:
        alpha_text = "alpha axis is alpha itself"
    conv = {
        "reference": "Walter et al. 2007, Microfacet Models for Refraction through Rough Surfaces",
        "frame": "macro normal n = +z; w_i = (sqrt(1 - mu^2), 0, mu); directions point away",
        "roughness_axis": rough,
        "alpha": alpha_text,
        "distribution": nspec["distribution"],
        "shadowing": nspec["shadowing"],
        "shadowing_definition": _SHADOWING_TEXT[nspec["shadowing"]],
        "fresnel": nspec["fresnel"],
    }
    if nspec["table"].startswith("sheen"):
        conv["distribution"] = "charlie (Estevez and Kulla 2017, Production Friendly Microfacet Sheen BRDF)"
        conv["shadowing"] = nspec.get("sheen_shadowing")
        conv["shadowing_definition"] = _SHEEN_SHADOWING.get(nspec.get("sheen_shadowing"), nspec.get("sheen_shadowing"))
    if nspec["table"] == "ltc":
        conv["amplitude"] = nspec.get("amplitude")
    if nspec["table"] == "albedo_aniso":
        conv["anisotropy"] = ("alpha_x = alpha / sqrt(1 - 0.9 a), alpha_y = alpha sqrt(1 - 0.9 a); phi_v is the view "
                              "azimuth from the tangent")
    if nspec["table"].startswith("dielectric"):
        conv["eta"] = "eta = eta_o / eta_i: IOR beyond the interface over IOR on the side of w_i"
        conv["transmission"] = "energy form: T = int f_t |cos theta_o| dw_o, R + T -> 1 as alpha -> 0"
    if nspec["table"] == "bsdf":
        conv["parametrization"] = nspec.get("parametrization")
        conv["angles"] = "radians; phi_d = phi_o - phi_i; f_t's theta_o measured from -n"
    if nspec["table"].endswith("_avg"):
        conv["average"] = "X_avg = 2 int_0^1 X(mu) mu dmu"
    return conv


def table_meta(nspec: dict, max_error: dict[str, float]) -> dict:
    """The metadata of a table of normalized spec ``nspec`` (the same for both paths)."""
    return {
        "table": nspec["table"],
        "spec": nspec,
        "conventions": conventions(nspec),
        "method": {
            "name": nspec["method"],
            **({"tolerance": nspec["tolerance"]} if "tolerance" in nspec else {}),  # none for a fixed rule
            "description": METHOD_TEXT.get(nspec["method"], nspec["method"]),
            "precision": "float64 (stored as float32)",
        },
        "max_error": max_error,
        "version": __version__,
    }


def _check_workers(workers: int | None) -> None:
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be a positive integer (None: all cores), got {workers!r}")


def _progress(progress: ProgressArg, desc: str):
    """(callback or None, bar or None): True shows a tqdm bar on stderr."""
    if callable(progress):
        return progress, None
    if progress is not True:
        return None, None
    from tqdm import tqdm

    bar = tqdm(total=0, unit="texel", unit_scale=True, desc=desc, leave=False, dynamic_ncols=True)

    def callback(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return callback, bar


def tabulate(
    spec: dict | str,
    *,
    device: str | None = None,
    workers: int | None = None,
    progress: ProgressArg = False,
    scheduler: Scheduler | None = None,
) -> Table:
    """Compute the table described by ``spec``.

    Parameters
    ----------
    spec : dict or str
        A table spec (see :mod:`bsdf_tab.spec`), as a dict or JSON text.
    device : str, optional
        Warp device ("cpu", "cuda:0"); default CUDA when available, else the CPU.
    workers : int, optional
        CPU worker threads (default: all cores this process may use); must be >= 1.
    progress : bool or callable
        True shows a progress bar on stderr; a callable receives (done, total) texel counts.
    scheduler : distributed.Client or str, optional
        Compute on a Dask cluster (:mod:`bsdf_tab.cluster`): a client, a scheduler address or
        ``"local:N"``. The table is the in-process one bit for bit. Default: in-process threads.

    Returns
    -------
    Table
        Axes, value and ``_err`` channels, and metadata (spec, conventions, method,
        max error, version).

    Raises
    ------
    SpecError
        If the spec is invalid (the message names the parameter).
    ValueError
        If ``device``, ``workers`` or ``scheduler`` is invalid (a scheduler that does not
        answer is a :class:`bsdf_tab.cluster.SchedulerError`, a ValueError).
    """
    if scheduler is not None:
        return next(iter(tabulate_many([spec], device=device, progress=progress, scheduler=scheduler)))[1]
    nspec = normalize_spec(spec)
    _check_workers(workers)
    axes = resolve_axes(nspec)
    dev = resolve_device(device)
    callback, bar = _progress(progress, nspec["table"])
    try:
        channels = KINDS[nspec["table"]]["compute"](nspec, axes, Context(dev, workers, callback))
    finally:
        if bar is not None:
            bar.close()
    return _table(nspec, axes, channels)


def check_finite(channels: dict, what: str = "table") -> None:
    """Raise :class:`~bsdf_tab.errors.NonFiniteTableError` if a computed channel is not finite.

    The last guard before a table reaches a caller or a writer: a value channel must be finite
    everywhere and an error channel must not be NaN (an infinite error is an honest "did not
    converge"). A spec the kernels cannot evaluate is refused by :func:`normalize_spec`; a NaN
    here is a bug, so it is an internal error rather than a silently wrong table.

    Parameters
    ----------
    channels : dict
        Channel name -> array (a whole table or a block of one).
    what : str
        What the message names (``"table albedo"``).

    Raises
    ------
    NonFiniteTableError
        Naming the channel and how many of its texels are not finite.
    """
    for name, values in channels.items():
        arr = np.asarray(values)
        bad = np.isnan(arr) if name.endswith("_err") else ~np.isfinite(arr)
        if bad.any():
            raise NonFiniteTableError(
                f"{what}: channel {name} has {int(bad.sum())} of {arr.size} texels "
                f"{'NaN' if name.endswith('_err') else 'NaN or infinite'} (a bug: please report it)")


def _table(nspec: dict, axes: dict, channels: dict) -> Table:
    check_finite(channels, f"table {nspec['table']}")  # never a table with NaN values
    table = Table(axes=axes, channels=channels, meta={})
    table.meta = table_meta(nspec, table.max_error())
    return table


def tabulate_many(
    specs,
    *,
    device: str | None = None,
    workers: int | None = None,
    progress: ProgressArg = False,
    scheduler: Scheduler | None = None,
) -> Iterator[tuple[int, Table]]:
    """Compute several tables; yield ``(index into specs, Table)`` as each one is done.

    In-process the tables come one after the other, in order. With a ``scheduler`` every
    chunk of every table is submitted at once (one graph: the workers stay busy across
    tables) and each table is yielded as its last chunk returns, so a caller writes it
    while the others compute. Parameters as for :func:`tabulate`; ``progress`` counts the
    texels of all tables.
    """
    nspecs = [normalize_spec(s) for s in specs]
    _check_workers(workers)
    if scheduler is None:
        for i, nspec in enumerate(nspecs):
            yield i, tabulate(nspec, device=device, workers=workers, progress=progress)
        return
    from . import cluster

    client, owned = cluster.connect(scheduler)
    callback, bar = _progress(progress, "tables")
    try:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        axes = [resolve_axes(n) for n in nspecs]
        tasks = [cluster.submit_table(client, i, n, a, n_workers=n_workers, device=device)
                 for i, (n, a) in enumerate(zip(nspecs, axes))]
        for i, channels in cluster.completed(client, tasks, callback):
            yield i, _table(nspecs[i], axes[i], channels)
    finally:
        if bar is not None:
            bar.close()
        if owned:
            cluster.close(client)


def streams(spec: dict | str) -> bool:
    """Whether the kind of ``spec`` is computed in blocks (so :func:`iter_blocks` bounds memory)."""
    return "blocks" in KINDS[normalize_spec(spec)["table"]]


@dataclass
class BlockStream:
    """A table computed block by block: iterate for ``(start, end, channels)``.

    Each block holds the axis-0 slices ``start:end`` of every channel (values and ``_err``),
    float64, shaped ``(end - start,) + shape[1:]``. After the iteration, :meth:`meta` is the
    metadata :func:`tabulate` would have recorded (its ``max_error`` taken over all blocks).
    """

    nspec: dict
    axes: dict[str, np.ndarray]
    channel_names: list[str]
    _blocks: Iterator = field(repr=False)
    _max_error: dict[str, float] = field(default_factory=dict, repr=False)
    _done: bool = field(default=False, repr=False)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.axes.values())

    def __iter__(self):
        for start, end, channels in self._blocks:
            check_finite(channels, f"table {self.nspec['table']}")  # before a streaming writer sees the block
            for name, values in channels.items():
                if name.endswith("_err"):
                    block_max = float(np.max(values)) if values.size else 0.0
                    key = name[: -len("_err")]
                    self._max_error[key] = max(self._max_error.get(key, 0.0), block_max)
            yield start, end, channels
        self._done = True

    def meta(self) -> dict:
        """The table's metadata; only complete once every block was produced."""
        if not self._done:
            raise RuntimeError("BlockStream.meta(): iterate over every block first")
        return table_meta(self.nspec, dict(self._max_error))


def iter_blocks(
    spec: dict | str,
    *,
    device: str | None = None,
    workers: int | None = None,
    progress: ProgressArg = False,
    block_texels: int | None = None,
    scheduler: Scheduler | None = None,
) -> BlockStream:
    """The table of ``spec`` as a stream of blocks of axis-0 slices (bounded memory).

    Kinds computed in blocks (:func:`streams`) yield about ``block_texels`` texels per block;
    the others yield the whole table as one block. With a ``scheduler`` the blocks are the
    cluster's chunks, in the order they complete (a streaming writer takes any order). The
    values are those of :func:`tabulate` bit for bit. Parameters as for :func:`tabulate`.
    """
    nspec = normalize_spec(spec)
    _check_workers(workers)
    if block_texels is not None and (isinstance(block_texels, bool) or not isinstance(block_texels, int)
                                     or block_texels < 1):
        raise ValueError(f"block_texels must be a positive integer, got {block_texels!r}")
    axes = resolve_axes(nspec)
    dev = resolve_device(device) if scheduler is None else None
    kind = KINDS[nspec["table"]]
    names = list(kind["channels"]) + [f"{c}_err" for c in kind["channels"]]

    def generate():
        callback, bar = _progress(progress, nspec["table"])
        ctx = Context(dev, workers, callback)
        try:
            if scheduler is not None:
                yield from _cluster_blocks(nspec, axes, scheduler, device, block_texels, callback)
            elif "blocks" in kind:
                extra = {} if block_texels is None else {"block_texels": block_texels}
                yield from kind["blocks"](nspec, axes, ctx, **extra)
            else:
                channels = kind["compute"](nspec, axes, ctx)
                yield 0, len(next(iter(axes.values()))), channels
        finally:
            if bar is not None:
                bar.close()

    return BlockStream(nspec=nspec, axes=axes, channel_names=names, _blocks=generate())


def _cluster_blocks(nspec, axes, scheduler, device, block_texels, callback):
    """Blocks of axis-0 slices computed on a cluster (a kind chunked on another axis: one block)."""
    from . import cluster

    client, owned = cluster.connect(scheduler)
    try:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        task = cluster.submit_table(client, 0, nspec, axes, n_workers=n_workers, target=block_texels, device=device)
        if task.axis == 0 and all(len(cut) == 1 for cut in task.spans):
            yield from cluster.completed_chunks(client, task, callback)
        else:
            for _i, channels in cluster.completed(client, [task], callback):
                yield 0, len(next(iter(axes.values()))), channels
    finally:
        if owned:
            cluster.close(client)
