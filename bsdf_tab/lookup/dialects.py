"""The five target languages: how each spells a float, a variable, a clamp, a fetch and a function.

A :class:`Dialect` turns the language-neutral steps of :mod:`bsdf_tab.lookup.emit` into source
text. Shading languages (GLSL, HLSL, WGSL) read the table as a texture in the file's image
layout (a 1-D, 2-D or 3-D texture, or a 2-D image with 3-D slices stacked) with exact texel
loads (``texelFetch`` / ``Load`` / ``textureLoad``: no filtering, no sampler state to get
wrong); C and Warp read one array per value channel in axis order.
"""

from __future__ import annotations

__all__ = ["DIALECTS", "Dialect", "LANGS"]

_SWIZZLE = "xyzw"


def _f(x: float) -> str:
    """A float literal that round-trips float32 (always with a dot or exponent)."""
    s = repr(float(x))
    if "e" in s or "E" in s:
        mant, exp = s.lower().split("e")
        if "." not in mant:
            mant += ".0"
        return f"{mant}e{int(exp)}"
    return s if "." in s else s + ".0"


class Dialect:
    """Spelling of one language (the base class writes C-like syntax)."""

    name = "base"
    comment = "//"
    suffix = ".txt"
    texture = True
    stmt_end = ";"
    indent = "    "

    def lit(self, x: float) -> str:
        return _f(x)

    def vec_type(self, n: int) -> str:
        raise NotImplementedError

    def decl(self, name: str, expr: str, kind: str = "float", mutable: bool = False) -> str:
        t = {"float": "float", "int": "int"}[kind] if kind in ("float", "int") else kind
        return f"{t} {name} = {expr};"

    def assign(self, name: str, expr: str) -> str:
        return f"{name} = {expr};"

    def clamp(self, x: str, lo: str, hi: str) -> str:
        return f"clamp({x}, {lo}, {hi})"

    def sqrt(self, x: str) -> str:
        return f"sqrt({x})"

    def imin(self, a: str, b: str) -> str:
        return f"min({a}, {b})"

    def to_int_floor(self, x: str) -> str:
        return f"int(floor({x}))"

    def to_float(self, x: str) -> str:
        return f"float({x})"

    def const_array(self, name: str, values) -> str:
        body = ", ".join(self.lit(v) for v in values)
        return f"const float {name}[{len(values)}] = float[{len(values)}]({body});"

    def for_begin(self, var: str, n: int) -> str:
        return f"for (int {var} = 0; {var} < {n}; ++{var}) {{"

    def if_begin(self, cond: str) -> str:
        return f"if ({cond}) {{"

    def block_end(self) -> str:
        return "}"

    def func_begin(self, name: str, params: list[tuple[str, str]], ret: str) -> str:
        args = ", ".join(f"{t} {n}" for n, t in params)
        return f"{ret} {name}({args}) {{"

    def func_end(self) -> str:
        return "}"

    def ret(self, expr: str) -> str:
        return f"return {expr};"

    def define(self, name: str, value: int) -> str:
        return f"#define {name} {value}"

    def flag(self, name: str) -> str:
        return f"({name} != 0)"

    def select(self, cond: str, a: str, b: str) -> str:
        return f"({cond} ? {a} : {b})"

    def fetch(self, ctx, coords: list[str], index: list[str]) -> str:
        """The load of one texel: ``coords`` (x[, y[, z]]) in the texture (shading languages),
        ``index`` the node index per table axis (C, Warp)."""
        raise NotImplementedError

    def lut_params(self, ctx) -> list[tuple[str, str]]:
        raise NotImplementedError


class GLSL(Dialect):
    name = "glsl"
    suffix = ".lookup.glsl"

    def vec_type(self, n: int) -> str:
        return "float" if n == 1 else f"vec{n}"

    def lut_params(self, ctx):
        return [("lut", f"sampler{ctx.tex_dims}D")]

    def fetch(self, ctx, coords, index):
        at = coords[0] if len(coords) == 1 else f"ivec{len(coords)}({', '.join(coords)})"
        return f"texelFetch(lut, {at}, 0).{_SWIZZLE[:ctx.nch]}"


class HLSL(Dialect):
    name = "hlsl"
    suffix = ".lookup.hlsl"

    def vec_type(self, n: int) -> str:
        return "float" if n == 1 else f"float{n}"

    def to_int_floor(self, x):
        return f"(int)floor({x})"

    def to_float(self, x):
        return f"(float)({x})"

    def const_array(self, name, values):
        body = ", ".join(self.lit(v) for v in values)
        return f"static const float {name}[{len(values)}] = {{{body}}};"

    def lut_params(self, ctx):
        return [("lut", f"Texture{ctx.tex_dims}D<float4>")]

    def fetch(self, ctx, coords, index):
        return f"lut.Load(int{len(coords) + 1}({', '.join(coords)}, 0)).{_SWIZZLE[:ctx.nch]}"


class WGSL(Dialect):
    name = "wgsl"
    suffix = ".lookup.wgsl"

    def vec_type(self, n: int) -> str:
        return "f32" if n == 1 else f"vec{n}<f32>"

    def decl(self, name, expr, kind="float", mutable=False):
        t = {"float": "f32", "int": "i32"}.get(kind, kind)
        return f"{'var' if mutable else 'let'} {name}: {t} = {expr};"

    def to_int_floor(self, x):
        return f"i32(floor({x}))"

    def to_float(self, x):
        return f"f32({x})"

    def const_array(self, name, values):
        body = ", ".join(self.lit(v) for v in values)
        return f"var<private> {name}: array<f32, {len(values)}> = array<f32, {len(values)}>({body});"

    def for_begin(self, var, n):
        return f"for (var {var}: i32 = 0; {var} < {n}; {var} = {var} + 1) {{"

    def func_begin(self, name, params, ret):
        args = ", ".join(f"{n}: {t}" for n, t in params)
        return f"fn {name}({args}) -> {ret} {{"

    def define(self, name, value):
        return f"const {name}: i32 = {value};"

    def select(self, cond, a, b):
        return f"select({b}, {a}, {cond})"

    def lut_params(self, ctx):
        return [("lut", f"texture_{ctx.tex_dims}d<f32>")]

    def fetch(self, ctx, coords, index):
        at = coords[0] if len(coords) == 1 else f"vec{len(coords)}<i32>({', '.join(coords)})"
        return f"textureLoad(lut, {at}, 0).{_SWIZZLE[:ctx.nch]}"


class C(Dialect):
    name = "c"
    suffix = ".lookup.h"
    texture = False

    def lit(self, x):
        return _f(x) + "f"

    def vec_type(self, n):
        return "void"

    def clamp(self, x, lo, hi):
        return f"fminf(fmaxf({x}, {lo}), {hi})"

    def sqrt(self, x):
        return f"sqrtf({x})"

    def imin(self, a, b):
        return f"(({a}) < ({b}) ? ({a}) : ({b}))"

    def to_int_floor(self, x):
        return f"(int)floorf({x})"

    def to_float(self, x):
        return f"(float)({x})"

    def const_array(self, name, values):
        body = ", ".join(self.lit(v) for v in values)
        return f"static const float {name}[{len(values)}] = {{{body}}};"

    def func_begin(self, name, params, ret):
        args = ", ".join(f"{t} {n}" for n, t in params)
        return f"static inline void {name}({args}) {{"

    def lut_params(self, ctx):
        return [(c, "const float *") for c in ctx.channel_params]

    def fetch(self, ctx, coords, index):
        flat = ctx.flat_index(index)
        return [f"{c}[{flat}]" for c in ctx.channel_params]


class Warp(Dialect):
    name = "warp"
    comment = "#"
    suffix = "_lookup.py"
    texture = False

    def vec_type(self, n):
        return "float" if n == 1 else f"wp.vec{n}"

    def decl(self, name, expr, kind="float", mutable=False):
        if mutable:
            return f"{name} = {'float' if kind == 'float' else 'int'}({expr})"
        return f"{name} = {expr}"

    def assign(self, name, expr):
        return f"{name} = {expr}"

    def clamp(self, x, lo, hi):
        return f"wp.clamp({x}, {lo}, {hi})"

    def sqrt(self, x):
        return f"wp.sqrt({x})"

    def imin(self, a, b):
        return f"wp.min({a}, {b})"

    def to_int_floor(self, x):
        return f"int(wp.floor({x}))"

    def const_array(self, name, values):
        body = ", ".join(self.lit(v) for v in values)
        return f"{name} = wp.constant(wp.types.vector(length={len(values)}, dtype=wp.float32)({body}))"

    def for_begin(self, var, n):
        return f"for {var} in range({n}):"

    def if_begin(self, cond):
        return f"if {cond}:"

    def block_end(self):
        return ""

    def func_begin(self, name, params, ret):
        args = ", ".join(f"{n}: {t}" for n, t in params)
        return f"@wp.func\ndef {name}({args}) -> {ret}:"

    def func_end(self):
        return ""

    def ret(self, expr):
        return f"return {expr}"

    def define(self, name, value):
        return f"{name} = {value}"

    def select(self, cond, a, b):
        return f"wp.where({cond}, {a}, {b})"

    def lut_params(self, ctx):
        return [(c, f"wp.array{ctx.ndim}d(dtype=wp.float32)") for c in ctx.channel_params]

    def fetch(self, ctx, coords, index):
        parts = [f"{c}[{', '.join(index)}]" for c in ctx.channel_params]
        return parts[0] if ctx.nch == 1 else f"wp.vec{ctx.nch}({', '.join(parts)})"


#: Language name -> dialect, in the order of ``--emit``'s choices.
DIALECTS: dict[str, Dialect] = {d.name: d for d in (GLSL(), HLSL(), WGSL(), C(), Warp())}
LANGS: tuple[str, ...] = tuple(DIALECTS)
