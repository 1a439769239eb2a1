"""``bsdf``: point values of one material's BSDF on an angular grid (no integration).

Parametrizations (``spec["parametrization"]``), all angles in radians, isotropic material:

``angles``: axes (theta_i, theta_o, phi_d).
    w_i = (sin theta_i, 0, cos theta_i); phi_d = phi_o - phi_i is the azimuth of w_o.
    ``f_r`` at w_o = (sin theta_o cos phi_d, sin theta_o sin phi_d, cos theta_o) (upper side);
    ``f_t`` at the lower-side direction w_o = (sin theta_o cos phi_d, sin theta_o sin phi_d,
    -cos theta_o): theta_o of a transmitted direction is measured from -n. phi_d = 0 is the
    side of w_i (back-scattering); the mirror direction is (theta_o, phi_d) = (theta_i, pi) and
    the straight-through direction o = -i is also (theta_i, pi) in ``f_t``.
``half_diff``: axes (theta_h, theta_d, phi_d), Rusinkiewicz 1998 with phi_h = 0 (isotropy).
    h = (sin theta_h, 0, cos theta_h); d = (sin theta_d cos phi_d, sin theta_d sin phi_d,
    cos theta_d) is w_i in the frame of h: w_i = R_y(theta_h) d, ``f_r`` at w_o = 2 (w_i.h) h - w_i.
    ``f_t`` at w_o = refract(w_i, h, eta): h is the generalized half-vector -(i + eta o)/|.|
    (Walter eq. 16) oriented to +n; 0 under total internal reflection. Reciprocity makes
    f(theta_h, theta_d, phi_d) = f(theta_h, theta_d, phi_d + pi) (for ``f_r``), so phi_d in
    [0, pi) suffices: the default axes are the MERL layout 90 x 90 x 180, theta_h = (i/90)^2 pi/2
    (square spacing, nodes "left"), theta_d = i pi/180, phi_d = i pi/180.

Channels ``f_r``, ``f_t`` (``f_t`` = 0 unless the Fresnel type is ``dielectric``; eta is the
Fresnel eta = eta_o / eta_i) and error channels ``f_r_err``, ``f_t_err``.

Error bound. The values are point evaluations in float64 (Warp kernel, the model's ``brdf`` /
``btdf``): no discretization error, only rounding. The error channel is a first-order rounding
bound, |f| * eps * (64 + K), eps = 2^-52, where 64 covers the arithmetic of F, G, D and the
divisions, and K the conditioning of the half-vector: the rounded h has |delta cos theta_h| <=
8 eps (reflection) or 8 eps (1 + eta) / |i + eta o| (transmission), amplified by
|d ln D / d cos theta_h| (GGX 4/c + 4/(c (alpha^2 c^2 + 1 - c^2)), Beckmann 4/c + 2/(c^3 alpha^2)),
by the Fresnel slope 1/g near the critical angle (dielectric, g = sqrt(eta^2 - 1 + c^2)), and
for transmission by 2x the relative error of the denominator (i.h) + eta (o.h) (= |i + eta o|)
and by the cancellation in 1 - F near total internal reflection ((16 + amp/g) / (1 - F)).
Stored EXR channels are float32 (relative rounding 2^-24 on top).

Memory: :func:`bake_bsdf_streaming` computes blocks of theta slices (axis 0) and writes them
through a memory-mapped temporary file to EXR (scanline by scanline) or ``.npz``, so a
full-size grid needs memory for one block only.
"""

from __future__ import annotations

import math
import os
import uuid
import zipfile
from pathlib import Path
from typing import Callable

import numpy as np
import warp as wp

from ..integrate.parallel import default_workers, resolve_device, run_chunks
from ..model import BECKMANN, FRESNEL_DIELECTRIC, brdf, btdf, fresnel_dielectric
from ..spec import normalize_spec, resolve_axes
from ._common import Context, integrator_params

__all__ = ["compute", "bake_bsdf_streaming", "material_alpha", "directions", "EPS_REL", "StreamedTable"]

CHANNELS = ("f_r", "f_t", "f_r_err", "f_t_err")
PARAM_ANGLES = wp.constant(0)
PARAM_HALF_DIFF = wp.constant(1)
_PARAM = {"angles": 0, "half_diff": 1}
#: Base relative rounding allowance of one point evaluation (in units of eps = 2^-52).
EPS_REL = 64.0
_EPS = 2.0**-52
#: Texels per kernel block (the streaming memory bound is ~ 4 channels x 8 bytes x this).
BLOCK_TEXELS = 1 << 20


@wp.func
def _dlnD_dc(c: wp.float64, alpha: wp.float64, dist: wp.int32):
    """|d ln D / d cos theta_h|: the amplification of an error in cos theta_h."""
    one = wp.float64(1.0)
    c = wp.max(c, wp.float64(1.0e-300))
    if dist == BECKMANN:
        return wp.float64(4.0) / c + wp.float64(2.0) / (c * c * c * alpha * alpha)
    return wp.float64(4.0) / c + wp.float64(4.0) / (c * (alpha * alpha * c * c + wp.max(one - c * c, wp.float64(0.0))))


@wp.func
def _fresnel_slope(ci: wp.float64, ftype: wp.int32, eta: wp.float64):
    """~|d ln F / d cos| of the dielectric Fresnel near the critical angle (1/g), else 0."""
    if ftype != FRESNEL_DIELECTRIC:
        return wp.float64(0.0)
    g2 = eta * eta - wp.float64(1.0) + ci * ci
    return wp.float64(1.0) / wp.sqrt(wp.max(wp.abs(g2), wp.float64(1.0e-16)))


@wp.func
def _directions(param: wp.int32, a0: wp.float64, a1: wp.float64, a2: wp.float64, eta: wp.float64):
    """(w_i, w_o reflected, w_o transmitted, ok_t) of one grid point (see the module docstring)."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    c2 = wp.cos(a2)
    s2 = wp.sin(a2)
    if param == PARAM_HALF_DIFF:
        ch = wp.cos(a0)
        sh = wp.sin(a0)
        sd = wp.sin(a1)
        cd = wp.cos(a1)
        dx = sd * c2
        dy = sd * s2
        h = wp.vec3d(sh, zero, ch)
        wi = wp.vec3d(ch * dx + sh * cd, dy, -sh * dx + ch * cd)
        wr = wp.float64(2.0) * cd * h - wi
        # refraction through h (Walter eq. 40), eta = eta_o / eta_i
        k2 = one - (one - cd * cd) / (eta * eta)
        wt = wp.vec3d(zero, zero, zero)
        ok = k2 >= zero
        if ok:
            wt = (cd / eta - wp.sqrt(k2)) * h - wi / eta
        return wi, wr, wt, ok
    si = wp.sin(a0)
    ci = wp.cos(a0)
    so = wp.sin(a1)
    co = wp.cos(a1)
    wi = wp.vec3d(si, zero, ci)
    wr = wp.vec3d(so * c2, so * s2, co)
    wt = wp.vec3d(so * c2, so * s2, -co)
    return wi, wr, wt, True


@wp.kernel
def _bsdf_block_kernel(
    idx: wp.array(dtype=wp.int32),
    ax0: wp.array(dtype=wp.float64),
    ax1: wp.array(dtype=wp.float64),
    ax2: wp.array(dtype=wp.float64),
    param: wp.int32,
    alpha: wp.float64,
    dist: wp.int32,
    shadowing: wp.int32,
    ftype: wp.int32,
    p0: wp.float64,
    p1: wp.float64,
    out: wp.array2d(dtype=wp.float64),
):
    k = idx[wp.tid()]
    n1 = ax1.shape[0]
    n2 = ax2.shape[0]
    i0 = k // (n1 * n2)
    r = k - i0 * n1 * n2
    i1 = r // n2
    i2 = r - i1 * n2
    one = wp.float64(1.0)
    eps = wp.float64(_EPS)
    wi, wr, wt, ok_t = _directions(param, ax0[i0], ax1[i1], ax2[i2], p0)

    fr = brdf(wi, wr, alpha, dist, shadowing, ftype, p0, p1)
    er = wp.float64(0.0)
    if fr != wp.float64(0.0):
        h = wp.normalize(wi + wr)
        kappa = _dlnD_dc(h[2], alpha, dist) + _fresnel_slope(wp.dot(wi, h), ftype, p0)
        er = wp.abs(fr) * eps * (wp.float64(EPS_REL) + wp.float64(8.0) * kappa)

    ft = wp.float64(0.0)
    et = wp.float64(0.0)
    if ftype == FRESNEL_DIELECTRIC and ok_t:
        ft = btdf(wi, wt, alpha, dist, shadowing, p0)
        if ft != wp.float64(0.0):
            v = wi + p0 * wt
            hl = wp.length(v)
            h = -v / hl
            if h[2] < wp.float64(0.0):
                h = -h
            amp = wp.float64(8.0) * (one + p0) / hl
            ci = wp.dot(wi, h)
            slope = _fresnel_slope(ci, ftype, p0)
            kappa = _dlnD_dc(h[2], alpha, dist) + slope + wp.float64(2.0)
            # 1 - F cancels near total internal reflection: abs. error of F over 1 - F
            tr = one - fresnel_dielectric(ci, p0)
            cancel = (wp.float64(16.0) + amp * slope) / wp.max(tr, wp.float64(1.0e-300))
            et = wp.abs(ft) * eps * (wp.float64(EPS_REL) + amp * kappa + cancel)
    out[0, k] = fr
    out[1, k] = ft
    out[2, k] = er
    out[3, k] = et


def material_alpha(nspec: dict) -> float:
    """The material's alpha of a normalized ``bsdf`` spec (``roughness**2`` if given so)."""
    if "roughness" in nspec:
        return float(nspec["roughness"]) ** 2
    return float(nspec["alpha"])


def directions(parametrization: str, a0, a1, a2, eta: float = 1.5):
    """NumPy float64 version of the kernel's direction setup (for tools and tests).

    Returns (w_i, w_o reflected, w_o transmitted, ok_t) broadcast over the angle arrays.
    """
    a0, a1, a2 = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (a0, a1, a2)))
    c2, s2 = np.cos(a2), np.sin(a2)
    if parametrization == "half_diff":
        ch, sh, cd, sd = np.cos(a0), np.sin(a0), np.cos(a1), np.sin(a1)
        dx, dy = sd * c2, sd * s2
        h = np.stack([sh, np.zeros_like(sh), ch], -1)
        wi = np.stack([ch * dx + sh * cd, dy, -sh * dx + ch * cd], -1)
        wr = 2.0 * cd[..., None] * h - wi
        k2 = 1.0 - (1.0 - cd * cd) / (eta * eta)
        ok = k2 >= 0.0
        wt = (cd / eta - np.sqrt(np.maximum(k2, 0.0)))[..., None] * h - wi / eta
        return wi, wr, np.where(ok[..., None], wt, 0.0), ok
    si, ci, so, co = np.sin(a0), np.cos(a0), np.sin(a1), np.cos(a1)
    wi = np.stack([si, np.zeros_like(si), ci], -1)
    wr = np.stack([so * c2, so * s2, co], -1)
    wt = np.stack([so * c2, so * s2, -co], -1)
    return wi, wr, wt, np.ones(a0.shape, dtype=bool)


# --------------------------------------------------------------------------- blocks


def _iter_blocks(nspec: dict, axes: dict, ctx: Context, block_texels: int = BLOCK_TEXELS):
    """Yield (i0_start, i0_end, values (4, nb, n1, n2) float64) over blocks of axis-0 slices."""
    names = list(axes)
    ax = [np.ascontiguousarray(axes[n], dtype=np.float64) for n in names]
    n0, n1, n2 = (len(a) for a in ax)
    per_slice = n1 * n2
    step = max(1, block_texels // per_slice)
    params = integrator_params(nspec)
    dev = ctx.device if ctx.device is not None else resolve_device(None)
    d_ax1 = wp.array(ax[1], dtype=wp.float64, device=dev)
    d_ax2 = wp.array(ax[2], dtype=wp.float64, device=dev)
    alpha = material_alpha(nspec)
    ctx.expect(n0 * per_slice)
    for start in range(0, n0, step):
        end = min(n0, start + step)
        n = (end - start) * per_slice
        d_ax0 = wp.array(ax[0][start:end], dtype=wp.float64, device=dev)
        d_out = wp.zeros((4, n), dtype=wp.float64, device=dev)

        def launch(idx):
            wp.launch(
                _bsdf_block_kernel,
                dim=idx.shape[0],
                inputs=[
                    idx, d_ax0, d_ax1, d_ax2, _PARAM[nspec["parametrization"]], alpha,
                    params["dist"], params["shadowing"], params["ftype"], params["fp0"], params["fp1"], d_out,
                ],
                device=dev,
            )

        chunk = None if dev.is_cuda else max(4096, -(-n // (4 * (ctx.workers or default_workers()))))
        run_chunks(n, launch, dev, workers=ctx.workers, chunk=chunk, progress=ctx.reporter())
        yield start, end, d_out.numpy().reshape(4, end - start, n1, n2)


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    """The whole table in memory: {f_r, f_t, f_r_err, f_t_err}, each shaped by the axes."""
    shape = tuple(len(a) for a in axes.values())
    out = np.empty((4,) + shape, dtype=np.float64)
    for start, end, vals in _iter_blocks(nspec, axes, ctx):
        out[:, start:end] = vals
    return {name: out[c] for c, name in enumerate(CHANNELS)}


# --------------------------------------------------------------------------- streaming


class StreamedTable:
    """What :func:`bake_bsdf_streaming` wrote: axes, meta and max errors (no channel data)."""

    def __init__(self, axes: dict, meta: dict, channels: tuple[str, ...] = CHANNELS):
        self.axes = axes
        self.meta = meta
        self.channel_names = list(channels)

    @property
    def kind(self) -> str:
        return self.meta["spec"]["table"]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.axes.values())

    def max_error(self) -> dict[str, float]:
        return dict(self.meta.get("max_error", {}))

    def __repr__(self) -> str:
        axes = " x ".join(f"{n}[{len(a)}]" for n, a in self.axes.items())
        return f"StreamedTable(bsdf: {axes})"


def _meta(nspec: dict, max_error: dict) -> dict:
    """The metadata :func:`bsdf_tab.tabulate` records (kept identical, tested)."""
    from .. import __version__
    from ..api import _METHOD_TEXT, conventions

    return {
        "table": nspec["table"],
        "spec": nspec,
        "conventions": conventions(nspec),
        "method": {
            "name": nspec["method"],
            "tolerance": nspec["tolerance"],
            "description": _METHOD_TEXT.get(nspec["method"], nspec["method"]),
            "precision": "float64 (stored as float32)",
        },
        "max_error": max_error,
        "version": __version__,
    }


def _progress_callback(progress, total_desc: str):
    if callable(progress):
        return progress, None
    if progress is True:
        from tqdm import tqdm

        bar = tqdm(total=0, unit="texel", unit_scale=True, desc=total_desc, leave=False, dynamic_ncols=True)

        def callback(done: int, total: int) -> None:
            bar.total = total
            bar.n = done
            bar.refresh()

        return callback, bar
    return None, None


def bake_bsdf_streaming(
    spec: dict | str,
    path,
    *,
    device: str | None = None,
    workers: int | None = None,
    progress: bool | Callable[[int, int], None] = False,
    block_texels: int = BLOCK_TEXELS,
) -> StreamedTable:
    """Compute a ``bsdf`` table block by block and write it to ``path`` with bounded memory.

    Parameters
    ----------
    spec : dict or str
        A ``bsdf`` spec.
    path : str or os.PathLike
        ``.exr`` (the layout of :func:`bsdf_tab.exr.write_exr`: axis-0 slices stacked
        vertically) or ``.npz`` (the layout of :meth:`Table.to_npz_bytes`, float64).
        ``read_exr`` / ``Table.from_npz_bytes`` read back exactly what
        ``tabulate(spec)`` would have written.
    device, workers, progress
        As for :func:`bsdf_tab.tabulate`.
    block_texels : int
        Texels computed per block (memory ~ 32 bytes each); a block is whole axis-0 slices.

    Returns
    -------
    StreamedTable
        Axes, metadata (with ``max_error``) of the written table.

    Notes
    -----
    Values go to a raw temporary file next to the output (channel-major; float32 for EXR,
    float64 for npz) with plain writes, because the metadata (``max_error``) precedes the
    pixels in both formats; the output is then written block by block from it and the
    temporary removed. Memory (resident) stays at a few blocks, disk needs about twice the
    output's uncompressed size.
    """
    nspec = normalize_spec(spec)
    if nspec["table"] != "bsdf":
        raise ValueError(f"bake_bsdf_streaming bakes bsdf tables, got table {nspec['table']!r}")
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".exr", ".npz"):
        raise ValueError(f"output {path}: streaming writes .exr or .npz")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")
    axes = resolve_axes(nspec)
    shape = tuple(len(a) for a in axes.values())
    dev = resolve_device(device)
    callback, bar = _progress_callback(progress, "bsdf")
    ctx = Context(dev, workers, callback)
    dtype = np.float32 if suffix == ".exr" else np.float64
    tag = f".{path.name}.{os.getpid()}.{uuid.uuid4().hex}"
    scratch = folder / (tag + ".raw")
    tmp_out = folder / (tag + ".tmp" + suffix)
    max_err = {"f_r": 0.0, "f_t": 0.0}
    try:
        step = max(1, block_texels // (shape[1] * shape[2]))
        with open(scratch, "w+b") as raw:
            store = _Scratch(raw, shape, dtype)
            try:
                for start, end, vals in _iter_blocks(nspec, axes, ctx, block_texels):
                    store.write(start, vals)
                    max_err["f_r"] = max(max_err["f_r"], float(vals[2].max()))
                    max_err["f_t"] = max(max_err["f_t"], float(vals[3].max()))
            finally:
                if bar is not None:
                    bar.close()
            meta = _meta(nspec, max_err)
            if suffix == ".exr":
                _write_exr_blocks(store, axes, meta, tmp_out, step)
            else:
                _write_npz(store, axes, meta, tmp_out)
        os.replace(tmp_out, path)
    finally:
        for p in (scratch, tmp_out):
            if p.exists():
                p.unlink()
    return StreamedTable(axes, meta)


class _Scratch:
    """Channel-major (4, n0, n1, n2) values in a raw file, written and read by axis-0 blocks."""

    def __init__(self, fh, shape: tuple[int, int, int], dtype):
        self.fh = fh
        self.shape = shape
        self.dtype = np.dtype(dtype)
        self.slice_bytes = shape[1] * shape[2] * self.dtype.itemsize
        self.plane_bytes = shape[0] * self.slice_bytes

    def write(self, start: int, vals: np.ndarray) -> None:
        for c in range(vals.shape[0]):
            self.fh.seek(c * self.plane_bytes + start * self.slice_bytes)
            self.fh.write(np.ascontiguousarray(vals[c], dtype=self.dtype).tobytes())

    def read(self, c: int, start: int, end: int) -> np.ndarray:
        self.fh.seek(c * self.plane_bytes + start * self.slice_bytes)
        data = self.fh.read((end - start) * self.slice_bytes)
        return np.frombuffer(data, dtype=self.dtype).reshape((end - start,) + self.shape[1:])


class _HeaderView:
    """Enough of a Table for :func:`bsdf_tab.exr._header` (names, axes, meta)."""

    def __init__(self, axes, meta):
        self.axes = axes
        self.meta = meta
        self.channels = dict.fromkeys(CHANNELS)


def _write_exr_blocks(store: _Scratch, axes: dict, meta: dict, out: Path, step: int) -> None:
    import OpenEXR

    from ..exr import ATTR_PREFIX, _header

    n0, n1, n2 = store.shape
    height, width = n0 * n1, n2
    attrs = {k: v for k, v in _header(_HeaderView(axes, meta)).items() if k.startswith(ATTR_PREFIX)}
    if not hasattr(OpenEXR, "OutputFile"):  # pragma: no cover - OpenEXR without the scanline writer
        from ..table import Table

        Table(axes, {name: store.read(c, 0, n0) for c, name in enumerate(CHANNELS)}, meta).write_exr(out)
        return
    header = OpenEXR.Header(width, height)
    proto = header["channels"]["R"]  # a FLOAT channel description
    header["channels"] = {name: proto for name in CHANNELS}
    for key, value in attrs.items():
        header[key] = value.encode("utf-8")
    exr = OpenEXR.OutputFile(str(out), header)
    try:
        for start in range(0, n0, step):
            end = min(n0, start + step)
            rows = (end - start) * n1
            exr.writePixels(
                {name: store.read(c, start, end).astype(np.float32).tobytes() for c, name in enumerate(CHANNELS)},
                rows,
            )
    finally:
        exr.close()


def _write_npz(store: _Scratch, axes: dict, meta: dict, out: Path) -> None:
    """The archive of :meth:`Table.to_npz_bytes`, each channel member streamed by blocks."""
    import json

    from ..table import json_default

    small = {"axis_order": np.array(list(axes), dtype=str)}
    small.update({f"axis/{n}": np.asarray(a, dtype=np.float64) for n, a in axes.items()})
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf:

        def member(name: str, arr: np.ndarray) -> None:
            with zf.open(name + ".npy", "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, arr, allow_pickle=False)

        for name, arr in small.items():
            member(name, arr)
        n0 = store.shape[0]
        step = max(1, (1 << 23) // store.slice_bytes)
        for c, name in enumerate(CHANNELS):
            with zf.open(f"channel/{name}.npy", "w", force_zip64=True) as fh:
                header = {"descr": np.lib.format.dtype_to_descr(store.dtype), "fortran_order": False,
                          "shape": store.shape}
                np.lib.format.write_array_header_1_0(fh, header)
                for start in range(0, n0, step):
                    fh.write(store.read(c, start, min(n0, start + step)).tobytes())
        member("channel_order", np.array(list(CHANNELS), dtype=str))
        member("meta", np.array(json.dumps(meta, default=json_default)))
