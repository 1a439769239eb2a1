"""Generated lookup code: a function that samples a table exactly as it was baked.

For a table file ``luts/dfg.exr``, :func:`emit_files` writes beside it ``dfg.lookup.glsl``,
``dfg.lookup.hlsl``, ``dfg.lookup.wgsl``, ``dfg.lookup.h`` (C99) and ``dfg_lookup.py`` (a Warp
``@wp.func``), each defining ``dfg_lookup``: the parameters are the physical values of the
axes (``NdotV`` for mu, ``roughness`` or ``alpha``, ``eta``), the result is the value channels
in table order (``vec2(A, B)``). The code computes each axis' texel coordinate as
:mod:`bsdf_tab.lookup.axes` defines it (spacing, node convention, range, clamp of the
coordinate), then interpolates multilinearly with exact texel loads:

- GLSL ``texelFetch``, HLSL ``Load``, WGSL ``textureLoad``: the table as the texture the file
  holds. ``native`` layout (``.ktx2``, ``.dds``: the writers store a 1-D, 2-D or 3-D texture as
  the table has 1, 2 or 3 axes): ``sampler1D`` / ``sampler2D`` / ``sampler3D`` (``Texture1D``,
  ``texture_1d``, ...), x = the last axis, y = axis 1 of a 3-D table (axis 0 of a 2-D one), z =
  axis 0. ``image`` layout (every other file: EXR, PNG, ...): a 2-D image, last axis along x,
  the other axes stacked along y, row = i0 * n1 + i1 (a 1-D table is one row). Row 0 = the
  file's first scanline; ``<P>_FLIP_Y`` (default 0) is for loaders that flip images vertically
  on upload. Value channel k is texture component k (``.x`` = the first value channel).
- C and Warp: one float32 array per value channel, shaped by the axes in axis order (what
  ``bsdf-tab``'s ``.h`` and ``npy-channels`` formats hold): ``dfg_lookup(lut_A, lut_B, NdotV,
  roughness, out)``.

The Python reference of the same lookup is :func:`bsdf_tab.lookup.lookup`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from ..io import write_text
from ..io.c_header import c_identifier
from .axes import LookupPlan, lookup_plan
from .dialects import DIALECTS, LANGS, Dialect

__all__ = ["LANGS", "LAYOUTS", "emit_files", "emit_source", "file_prefix", "output_paths", "texture_layout"]

MAX_CHANNELS = 4
MAX_AXES = 3


#: Texture layouts: ``image`` (a 2-D image, 3-D tables' slices stacked along y: EXR, PNG and the
#: formats without a texture type) and ``native`` (the texture type of the table's dimension:
#: 1-D, 2-D or 3-D, what the KTX2 and DDS writers store).
LAYOUTS = ("image", "native")
_NATIVE_SUFFIXES = (".ktx2", ".dds")


def texture_layout(table_file) -> str:
    """The texture layout of a table file: ``native`` for ``.ktx2`` and ``.dds``, else ``image``."""
    return "native" if str(table_file).lower().endswith(_NATIVE_SUFFIXES) else "image"


@dataclass
class _Ctx:
    plan: LookupPlan
    prefix: str
    layout: str = "image"
    table_stem: str = "table"

    @property
    def tex_dims(self) -> int:
        """Dimension of the texture the shading languages sample (1, 2 or 3)."""
        return self.ndim if self.layout == "native" else 2

    @property
    def macro(self) -> str:
        return self.prefix.upper()

    @property
    def data_prefix(self) -> str:
        """The prefix of the ``.h`` data file of the same name (:func:`bsdf_tab.io.c_header.write_header`)."""
        return c_identifier(self.table_stem)

    @property
    def nch(self) -> int:
        return len(self.plan.channels)

    @property
    def ndim(self) -> int:
        return len(self.plan.axes)

    @property
    def channel_params(self) -> list[str]:
        return [f"lut_{c_identifier(c)}" for c in self.plan.channels]

    def flat_index(self, index: list[str]) -> str:
        sizes = self.plan.shape
        expr = index[0]
        for k in range(1, len(index)):
            expr = f"({expr}) * {sizes[k]} + {index[k]}"
        return expr


def file_prefix(out_path) -> str:
    """The identifier prefix of a table file: its name up to the first dot (as the ``.h`` format's),
    non-alphanumerics as ``_``; a name that does not start with a letter gets ``lut_`` in front
    (``3d-lut.ktx2`` -> ``lut_3d_lut``: no identifier, macro included, starts with a digit or an
    underscore, which C reserves as ``_X`` / ``__``)."""
    ident = c_identifier(Path(out_path).name.split(".")[0] or "table")
    if not ident[0].isalpha():
        ident = "lut_" + (ident.lstrip("_") or "table")
    return ident


def output_paths(out_path, langs) -> list[Path]:
    """Where :func:`emit_files` writes the code for ``langs`` beside the table file ``out_path``."""
    out = Path(out_path)
    base = out.name.split(".")[0] or "table"
    return [out.with_name(base + DIALECTS[_check_lang(lang)].suffix) for lang in langs]


def _check_lang(lang: str) -> str:
    if lang not in DIALECTS:
        raise ValueError(f"emit: unknown language {lang!r}; choose from {', '.join(LANGS)}")
    return lang


def _header(d: Dialect, ctx: _Ctx, table_file: str) -> list[str]:
    plan = ctx.plan
    c = d.comment
    width, height = plan.image_size()
    name = f"{ctx.prefix}_lookup"
    lines = [f"{c} {Path(table_file).name}: lookup generated by bsdf-tab. Do not edit.",
             f"{c} table: {plan.kind}; shape {' x '.join(str(s) for s in plan.shape)} "
             f"[{', '.join(a.name for a in plan.axes)}]"]
    for key in ("value", "distribution", "shadowing", "shadowing_definition", "alpha", "layout"):
        if key in plan.conventions:
            text = plan.conventions[key]
            lines.append(f"{c} {key}: {text if isinstance(text, str) else json.dumps(text)}")
    params = ", ".join(a.param for a in plan.axes)
    comps = ", ".join(f"{'xyzw'[k] if d.texture else k} = {ch}" for k, ch in enumerate(plan.channels))
    lines.append(f"{c} {name}({'lut' if d.texture else ', '.join(ctx.channel_params)}, {params}) -> ({comps})")
    for a in plan.axes:
        lines.append(f"{c}   {a.param}: {a.formula()}")
    lines.append(f"{c}   multilinear in t between nodes floor(t) and floor(t) + 1; t is clamped (ends held)")
    if d.texture:
        ax = plan.axes
        flip = f"set {ctx.macro}_FLIP_Y to 1 if the loader flips images vertically"
        if ctx.tex_dims == 1:
            lines.append(f"{c} texture: 1-D, width {ax[0].size} (x = {ax[0].name} index); "
                         "the KTX2 / DDS texture as written")
            flip = "no vertical flip applies to a 1-D texture"
        elif ctx.tex_dims == 3:
            lines.append(f"{c} texture: 3-D, width {ax[2].size} (x = {ax[2].name} index), height {ax[1].size} "
                         f"(y = {ax[1].name} index), depth {ax[0].size} (z = {ax[0].name} index); "
                         "the KTX2 / DDS volume as written, y = 0 the first row of each slice")
        else:
            rows = " * ".join(f"{a.name} {a.size}" for a in ax[:-1]) or "1"
            lines.append(f"{c} texture: 2-D, width {width} (x = {ax[-1].name} index), height {height} (y = row = "
                         + (f"i_{ax[0].name}" if ctx.ndim == 2 else
                            f"i_{ax[0].name} * {ax[1].size} + i_{ax[1].name}" if ctx.ndim == 3 else "0")
                         + f"; {rows} rows), row 0 = the file's first scanline"
                         + (" (3-D slices stacked along y, as the EXR and PNG writers store them)" if ctx.ndim == 3
                            else ""))
        lines.append(f"{c}   component k = value channel k ({', '.join(plan.channels)}): bind the file's channels "
                     f"in that order; exact texel loads, no sampler state; {flip}")
    else:
        index = "".join(f"[i_{a.name}]" for a in plan.axes)
        lines.append(f"{c} arrays: one float32 array per value channel in axis order (C order), "
                     f"lut_<channel>{index}; bsdf-tab's .h file holds them as {ctx.data_prefix}_<channel> "
                     f"(its {ctx.data_prefix.upper()}_NUM_CHANNELS counts the error channels too: "
                     f"{ctx.macro}_NUM_VALUE_CHANNELS = {ctx.nch} value channels here)")
    return lines


def _axis_steps(d: Dialect, ctx: _Ctx, k: int) -> list[str]:
    a = ctx.plan.axes[k]
    n = a.size
    lines = []
    if n == 1:
        if d.name == "c":
            lines.append(f"(void){a.param}; /* one node: the coordinate is not read */")
        lines.append(d.decl(f"t{k}", d.lit(0.0)))
    elif a.kind == "nodes":
        arr = f"{ctx.macro}_X{k}"
        lo, hi = a.bounds()
        lines.append(d.decl(f"x{k}", d.clamp(a.param, d.lit(lo), d.lit(hi))))
        lines.append(d.decl(f"t{k}", d.lit(0.0), mutable=True))
        lines.append(d.for_begin("i", n - 1))
        frac = d.clamp(f"(x{k} - {arr}[i]) / ({arr}[i + 1] - {arr}[i])", d.lit(0.0), d.lit(1.0))
        # the last node i on the near side of x: x_i <= x (increasing nodes), x_i >= x (decreasing)
        lines.append(d.indent + d.if_begin(f"x{k} {'<=' if a.decreasing else '>='} {arr}[i]"))
        lines.append(2 * d.indent + d.assign(f"t{k}", f"{d.to_float('i')} + {frac}"))
        lines.append(d.indent + d.block_end())
        lines.append(d.block_end())
    else:
        glo, _, scale, offset = a.scale_offset()
        lo, hi = a.bounds()
        x = d.clamp(a.param, d.lit(lo), d.lit(hi))
        g = d.sqrt(x) if a.spacing == "square" else x
        if scale < 0:  # decreasing axis: node 0 at the high end
            g = f"({d.lit(glo)} - {g})"
        elif glo != 0.0:
            g = f"({g} - {d.lit(glo)})"
        expr = f"{g} * {d.lit(abs(scale))}" + (f" - {d.lit(-offset)}" if offset else "")
        lines.append(d.decl(f"t{k}", d.clamp(expr, d.lit(0.0), d.lit(n - 1.0))))
    lines.append(d.decl(f"i{k}", d.imin(d.to_int_floor(f"t{k}"), str(max(n - 2, 0))), kind="int"))
    lines.append(d.decl(f"f{k}", f"t{k} - {d.to_float(f'i{k}')}"))
    lines.append(d.decl(f"j{k}", d.imin(f"i{k} + 1", str(n - 1)), kind="int"))
    return [ln for ln in lines if ln != ""] if d.name != "warp" else [ln for ln in lines if ln.strip()]


def _corner_index(ctx: _Ctx, bits: int) -> list[str]:
    return [f"{'j' if (bits >> (ctx.ndim - 1 - k)) & 1 else 'i'}{k}" for k in range(ctx.ndim)]


def _texel(d: Dialect, ctx: _Ctx, index: list[str]) -> str:
    """The texel load of the node ``index`` (one index per axis) in the texture's coordinates."""
    sizes = ctx.plan.shape
    x = index[-1]
    if ctx.tex_dims == 1:  # a 1-D texture (native layout of a 1-D table)
        return d.fetch(ctx, [x], index)
    if ctx.tex_dims == 3:  # a volume: x = last axis, y = axis 1, z = axis 0
        y, z, height = index[1], index[0], sizes[1]
    else:
        z = None
        if ctx.ndim == 1:
            y = "0"
        elif ctx.ndim == 2:
            y = index[0]
        else:
            y = f"{index[0]} * {sizes[1]} + {index[1]}"
        _, height = ctx.plan.image_size()
    flag = f"{ctx.macro}_FLIP_Y"
    y = d.select(d.flag(flag), f"{height - 1} - ({y})", y) if height > 1 else y
    return d.fetch(ctx, [x, y] if z is None else [x, y, z], index)


def _lerp(a: str, b: str, f: str) -> str:
    return f"{a} + ({b} - {a}) * {f}"


def _body(d: Dialect, ctx: _Ctx) -> list[str]:
    ind = d.indent
    lines = []
    for k in range(ctx.ndim):
        lines += [ind + ln for ln in _axis_steps(d, ctx, k)]
    nd = ctx.ndim
    vtype = d.vec_type(ctx.nch)
    if d.name == "c":
        for ci, cp in enumerate(ctx.channel_params):
            level = {}
            for bits in range(1 << nd):
                idx = ctx.flat_index(_corner_index(ctx, bits))
                lines.append(ind + d.decl(f"c{ci}_{bits}", f"{cp}[{idx}]"))
                level[bits] = f"c{ci}_{bits}"
            lines += _reduce(d, level, nd, f"c{ci}", ind)
            lines.append(ind + f"out[{ci}] = c{ci}_r{nd};")
        return lines
    level = {}
    for bits in range(1 << nd):
        expr = _texel(d, ctx, _corner_index(ctx, bits)) if d.texture else d.fetch(ctx, [], _corner_index(ctx, bits))
        lines.append(ind + d.decl(f"c_{bits}", expr, kind=vtype))
        level[bits] = f"c_{bits}"
    lines += _reduce(d, level, nd, "c", ind, vtype)
    lines.append(ind + d.ret(f"c_r{nd}"))
    return lines


def _reduce(d: Dialect, level: dict, nd: int, stem: str, ind: str, kind: str = "float") -> list[str]:
    """Interpolate the 2^nd corners, the last axis first (f_{nd-1}), down to one value ``<stem>_r<nd>``."""
    lines = []
    for step in range(nd):
        axis = nd - 1 - step
        nxt = {}
        for bits in range(0, 1 << (nd - step), 2):
            name = f"{stem}_r{step + 1}_{bits >> 1}" if step + 1 < nd else f"{stem}_r{nd}"
            lines.append(ind + d.decl(name, _lerp(level[bits], level[bits + 1], f"f{axis}"), kind=kind))
            nxt[bits >> 1] = name
        level = nxt
    return lines


def emit_source(table, lang: str, table_file: str = "table.exr", plan: LookupPlan | None = None,
                layout: str | None = None) -> str:
    """The lookup code for ``table`` in ``lang`` (one of :data:`LANGS`).

    Parameters
    ----------
    table : Table
        The table as written (its axes, channels and meta).
    lang : str
        ``glsl``, ``hlsl``, ``wgsl``, ``c`` or ``warp``.
    table_file : str
        The table file's name: the function is ``<name up to the first dot>_lookup``.
    plan : LookupPlan, optional
        Default :func:`bsdf_tab.lookup.lookup_plan` of the table.
    layout : str, optional
        The texture the shading languages sample: ``native`` (a 1-D, 2-D or 3-D texture as the
        table has 1, 2 or 3 axes: what the KTX2 and DDS writers store) or ``image`` (a 2-D image,
        3-D slices stacked along y: EXR, PNG). Default :func:`texture_layout` of ``table_file``.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        For an unknown language or layout, more than 3 axes, more than 4 value channels, or an
        axis whose values neither increase nor decrease.
    """
    d = DIALECTS[_check_lang(lang)]
    plan = plan or lookup_plan(table)
    if not 1 <= len(plan.axes) <= MAX_AXES:
        raise ValueError(f"emit: lookup code is generated for tables of 1 to {MAX_AXES} axes, got {len(plan.axes)}")
    if not 1 <= len(plan.channels) <= MAX_CHANNELS:
        raise ValueError(f"emit: lookup code is generated for 1 to {MAX_CHANNELS} value channels, "
                         f"got {len(plan.channels)}")
    layout = layout or texture_layout(table_file)
    if layout not in LAYOUTS:
        raise ValueError(f"emit: unknown texture layout {layout!r}; choose from {', '.join(LAYOUTS)}")
    ctx = _Ctx(plan, file_prefix(table_file), layout, Path(table_file).name.split(".")[0] or "table")
    out = _header(d, ctx, table_file)
    out.append("")
    if d.name == "c":
        guard = f"{ctx.macro}_LOOKUP_H"
        out += [f"#ifndef {guard}", f"#define {guard}", "#include <math.h>", ""]
    if d.name == "warp":
        out += ["import warp as wp", ""]
    if d.texture:
        out.append(d.define(f"{ctx.macro}_FLIP_Y", 0))
    # the value channels the lookup returns (the .h data file's <P>_NUM_CHANNELS counts error channels too)
    out.append(d.define(f"{ctx.macro}_NUM_VALUE_CHANNELS", ctx.nch))
    for k, a in enumerate(plan.axes):
        if a.kind == "nodes" and a.size > 1:
            out.append(d.const_array(f"{ctx.macro}_X{k}", a.values))
    out.append("")
    params = d.lut_params(ctx) + [(a.param, {"wgsl": "f32"}.get(d.name, "float")) for a in plan.axes]
    if d.name == "c":
        params.append((f"out[{ctx.nch}]", "float"))
    out.append(d.func_begin(f"{ctx.prefix}_lookup", params, d.vec_type(ctx.nch)))
    out += _body(d, ctx)
    end = d.func_end()
    if end:
        out.append(end)
    if d.name == "c":
        out += ["", f"#endif /* {guard} */"]
    return "\n".join(out) + "\n"


def emit_files(table, out_path, langs, layout: str | None = None) -> list[Path]:
    """Write, beside the table file ``out_path``, its lookup function in each of ``langs``.

    Parameters
    ----------
    table : Table
        The table that was written to ``out_path`` (axes, channels, meta).
    out_path : str or os.PathLike
        The table file (``luts/dfg.exr``): the code goes beside it (``luts/dfg.lookup.glsl``,
        ``dfg.lookup.hlsl``, ``dfg.lookup.wgsl``, ``dfg.lookup.h``, ``dfg_lookup.py``) and the
        function is ``dfg_lookup``.
    langs : iterable of str
        Languages from :data:`LANGS` (``glsl``, ``hlsl``, ``wgsl``, ``c``, ``warp``).
    layout : str, optional
        ``native`` or ``image`` (see :func:`emit_source`); default from the file's ending:
        ``native`` for ``.ktx2`` and ``.dds``, ``image`` otherwise.

    Returns
    -------
    list of pathlib.Path
        The files written, in the order of ``langs``.

    Raises
    ------
    ValueError
        For an unknown language or a table the generator does not cover (see :func:`emit_source`).
    """
    langs = [_check_lang(lang) for lang in langs]
    plan = lookup_plan(table)
    # all checked before anything is written
    texts = [emit_source(table, lang, str(out_path), plan=plan, layout=layout) for lang in langs]
    written = []
    for path, text in zip(output_paths(out_path, langs), texts):
        written.append(write_text(path, text))
    return written
