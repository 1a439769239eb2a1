"""``tabulate(spec) -> Table``: the one path from a spec to a table (CLI and service use it)."""

from __future__ import annotations

from typing import Callable

from . import __version__
from .integrate.parallel import resolve_device
from .spec import normalize_spec, resolve_axes
from .table import Table
from .tables import COMPUTE, Context

_SHADOWING_TEXT = {
    "separable": "separable G = G1(i) G1(o) (Walter 2007)",
    "correlated": "height-correlated G = 1 / (1 + Lambda(i) + Lambda(o)) (Heitz 2014)",
}
_METHOD_TEXT = {
    "adaptive": "nested adaptive Gauss-Kronrod (G7-K15) over micro-normal space, split at the "
    "closed-form horizon / critical-angle curves; error = sum over accepted intervals of "
    "QUADPACK's rescaled |K15 - G7| (resasc * min(1, (200 |K15 - G7| / resasc)^1.5)) plus "
    "propagated inner errors",
    "point": "float64 point evaluation of the BSDF (Walter eqs. 20 and 21); error = rounding bound",
}


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
    if nspec["table"].startswith("dielectric"):
        conv["eta"] = "eta = eta_o / eta_i: IOR beyond the interface over IOR on the side of w_i"
        conv["transmission"] = "energy form: T = int f_t |cos theta_o| dw_o, R + T -> 1 as alpha -> 0"
    if nspec["table"] == "bsdf":
        conv["parametrization"] = nspec.get("parametrization")
        conv["angles"] = "radians; phi_d = phi_o - phi_i; f_t's theta_o measured from -n"
    if nspec["table"].endswith("_avg"):
        conv["average"] = "X_avg = 2 int_0^1 X(mu) mu dmu"
    return conv


def tabulate(
    spec: dict | str,
    *,
    device: str | None = None,
    workers: int | None = None,
    progress: bool | Callable[[int, int], None] = False,
) -> Table:
    """Compute the table described by ``spec``.

    Parameters
    ----------
    spec : dict or str
        A table spec (see :mod:`bsdf_tab.spec`), as a dict or JSON text.
    device : str, optional
        Warp device ("cpu", "cuda:0"); default CUDA when available, else the CPU.
    workers : int, optional
        CPU worker threads (default: all cores this process may use).
    progress : bool or callable
        True shows a progress bar on stderr; a callable receives (done, total) texel counts.

    Returns
    -------
    Table
        Axes, value and ``_err`` channels, and metadata (spec, conventions, method,
        max error, version).

    Raises
    ------
    SpecError
        If the spec is invalid (the message names the parameter).
    """
    nspec = normalize_spec(spec)
    axes = resolve_axes(nspec)
    dev = resolve_device(device)
    bar = None
    callback = progress if callable(progress) else None
    if progress is True:
        from tqdm import tqdm

        bar = tqdm(total=0, unit="texel", desc=nspec["table"], leave=False, dynamic_ncols=True)

        def callback(done: int, total: int) -> None:
            bar.total = total
            bar.n = done
            bar.refresh()

    try:
        channels = COMPUTE[nspec["table"]](nspec, axes, Context(dev, workers, callback))
    finally:
        if bar is not None:
            bar.close()
    table = Table(axes=axes, channels=channels, meta={})
    table.meta = {
        "table": nspec["table"],
        "spec": nspec,
        "conventions": conventions(nspec),
        "method": {
            "name": nspec["method"],
            "tolerance": nspec["tolerance"],
            "description": _METHOD_TEXT.get(nspec["method"], nspec["method"]),
            "precision": "float64 (stored as float32)",
        },
        "max_error": table.max_error(),
        "version": __version__,
    }
    return table
