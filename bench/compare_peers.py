"""Compare bsdf-tab's engine presets with the tables the engines ship.

Run: ``python bench/compare_peers.py [--device cpu] [--only NAME ...] [--reuse]`` (or
``bsdf-tab bench compare_peers ...``).

For every preset that has a peer table in the anchors folder (``../shared/anchors`` relative
to the repository root, or ``$BSDF_TAB_ANCHORS``), bakes the preset at full size, loads the
peer's array, checks that the axes agree with the peer's axis files, and reports:

- max and mean |ours - theirs| over all texels, and where the max is (axis values);
- the mean and max signed difference theirs - ours (a bias shows here, e.g. Cycles'
  ``ggx_glass_inv_E``);
- the same max / mean over the *interior*: texels off the nodes where the peer uses a
  convention of its own (Cycles glass: the ior ~ 1 slice; OpenPBR: roughness 0, cos 0 and
  its two ior = 1 slices);
- for tables with a mu axis, the interior max |difference| at each mu node (a grazing-angle bias shows);
- our largest error estimate, for scale.

Prints a table and writes ``bench/out/compare_peers.json``. Our baked tables are cached in
``bench/out/presets/*.npz`` (``--reuse`` reads them instead of recomputing). Skips cleanly
(exit 0) when the anchors folder is absent. Peer data is only read, never copied into the repo.

The engine presets without a table in the anchors are compared with the engines' shipped
numbers (``--engines``; each skips cleanly without its input; ``--engines-only`` skips the
anchors' tables):

- EEVEE ``--eevee-lut PATH``: a copy of Blender's ``eevee_lut.cc`` (or an excerpt holding the
  declaration of ``brdf_ggx`` / ``bsdf_split_sum_ggx`` and some of its rows, the first of them
  ``--eevee-first-row``), against ``eevee-brdf-split-sum`` on the same rows;
- MaterialX ``mx_ggx_dir_albedo_analytic`` (``--materialx PATH``, default the anchors' JSON):
  the rational fit of (A, B) in (NdotV, alpha) against the exact height-correlated table;
- Unreal's mobile ``EnvBRDFApprox`` (Karis' analytic fit, also Bevy's ``F_AB``) against
  ``unreal-envbrdf`` and ``bevy-dfg``;
- Godot's ``integrate_dfg.glsl``, run here in float64 NumPy as the shader writes it (1024
  Hammersley samples, GGX NDF sampling, Schlick-GGX G with k = roughness^2 / 2, row y at
  roughness (128 - y + 0.5) / 128, RGBA16F rounding), against ``godot-dfg``;
- the glTF Sample Viewer's ``LUT()`` of ``ibl_filtering.frag`` (Hammersley NDF sampling,
  ``V_SmithGGXCorrelated``; ``--gltf-samples``, default 512 and 1024) against ``gltf-ggx-lut`` on
  every 16th texel (its shipped ``lut_ggx.png`` is binary and not read here).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "bench" / "out"
if str(ROOT) not in sys.path:  # the checkout's bsdf_tab, as for bench/accuracy.py
    sys.path.insert(0, str(ROOT))

from bsdf_tab.presets import PRESETS, build_preset  # noqa: E402
from bsdf_tab.table import Table  # noqa: E402


def anchors_dir() -> Path:
    return Path(os.environ.get("BSDF_TAB_ANCHORS") or (ROOT.parent / "shared" / "anchors"))


def interior_mask(name: str, shape: tuple[int, ...], axes: list[str]) -> np.ndarray:
    """Texels off the nodes where the peer follows a convention of its own."""
    mask = np.ones(shape, dtype=bool)

    def drop(axis: str, index: int) -> None:
        if axis in axes:
            sl = [slice(None)] * len(shape)
            sl[axes.index(axis)] = index
            mask[tuple(sl)] = False

    if name.startswith("cycles-ggx-glass"):
        drop("ior", 0)  # ior = 1.00000002: Cycles ~1 (interface invisible), ours the microfacet limit
    if name.startswith("openpbr-"):
        drop("roughness", 0)  # OpenPBR: 0 there (no loss)
        drop("cos", 0)  # OpenPBR: not the mu -> 0 limit
        if "ior" in axes:  # OpenPBR's two ior = 1 slices differ from each other: not exactly eta = 1
            drop("ior", 15)
            drop("ior", 16)
    return mask


def where(table: Table, index: tuple[int, ...]) -> dict:
    return {n: float(a[i]) for (n, a), i in zip(table.axes.items(), index)}


def compare(name: str, table: Table, theirs: np.ndarray, anchors: Path) -> dict:
    preset = PRESETS[name]
    channel = table.value_channels[0]
    ours = np.asarray(table.channels[channel], dtype=np.float64)
    err = np.asarray(table.channels[channel + "_err"], dtype=np.float64)
    if ours.shape != theirs.shape:
        return {"preset": name, "error": f"shape {ours.shape} != peer {theirs.shape}"}
    axis_check = {}
    for axis, rel in preset.anchor_axes.items():
        path = anchors / rel
        if path.exists():
            axis_check[axis] = float(np.max(np.abs(np.load(path) - table.axes[axis])))
    diff = ours - theirs
    absd = np.abs(diff)
    imax = np.unravel_index(int(np.argmax(absd)), absd.shape)
    signed = theirs - ours
    ibias = np.unravel_index(int(np.argmax(signed)), signed.shape)
    mask = interior_mask(name, ours.shape, list(table.axes))
    inner = absd[mask]
    imax_in = np.unravel_index(int(np.argmax(np.where(mask, absd, -1.0))), absd.shape)
    return {
        "preset": name,
        "peer": preset.peer,
        "anchor": preset.anchor,
        "channel": channel,
        "shape": list(ours.shape),
        "axis_order": list(table.axes),
        "axis_max_abs_diff": axis_check,
        "max_abs_diff": float(absd.max()),
        "mean_abs_diff": float(absd.mean()),
        "max_at": {**where(table, imax), "ours": float(ours[imax]), "theirs": float(theirs[imax])},
        "mean_signed_theirs_minus_ours": float(signed.mean()),
        "max_signed_theirs_minus_ours": float(signed.max()),
        "max_signed_at": {**where(table, ibias), "ours": float(ours[ibias]), "theirs": float(theirs[ibias])},
        "interior_texels": int(mask.sum()),
        "interior_max_abs_diff": float(inner.max()) if inner.size else None,
        "interior_mean_abs_diff": float(inner.mean()) if inner.size else None,
        "interior_max_at": {**where(table, imax_in), "ours": float(ours[imax_in]), "theirs": float(theirs[imax_in])},
        "fraction_above_1e-3": float((absd > 1e-3).mean()),
        "max_abs_diff_by_mu": (
            [float(x) for x in np.moveaxis(np.where(mask, absd, 0.0), list(table.axes).index("mu"), 0)
             .reshape(absd.shape[list(table.axes).index("mu")], -1).max(axis=1)]
            if "mu" in table.axes else None
        ),
        "max_abs_diff_mu_above_first": (
            float(np.moveaxis(np.where(mask, absd, 0.0), list(table.axes).index("mu"), 0)[1:].max())
            if "mu" in table.axes else None
        ),
        "our_max_error_estimate": float(err.max()),
    }



# ----------------------------------------------------------------------------- engines' own numbers


def _stats(ours: np.ndarray, theirs: np.ndarray, axes: dict) -> dict:
    """max / mean |ours - theirs|, where the max is (axis values), mean signed theirs - ours."""
    d = np.abs(ours - theirs)
    k = np.unravel_index(int(np.nanargmax(d)), d.shape)
    at = {n: float(np.asarray(v)[i]) for (n, v), i in zip(axes.items(), k)}
    return {"max_abs_diff": float(np.nanmax(d)), "mean_abs_diff": float(np.nanmean(d)),
            "mean_signed_theirs_minus_ours": float(np.nanmean(theirs - ours)),
            "max_at": {**at, "ours": float(ours[k]), "theirs": float(theirs[k])}}


def eevee_split_sum_rows(path: Path, first_row: int) -> tuple[np.ndarray, np.ndarray]:
    """(rows, 64, 2) of EEVEE's split-sum LUT from ``eevee_lut.cc`` (or an excerpt), and the row indices."""
    from bsdf_tab.doctor.readers import read_array_text

    text = path.read_text(encoding="utf-8", errors="replace")
    import re

    m = re.search(r"\b(brdf_ggx|bsdf_split_sum_ggx)\s*\[64\]\s*\[64\]", text)
    if m is None:
        raise ValueError(f"{path}: no brdf_ggx[64][64] / bsdf_split_sum_ggx[64][64] declaration")
    body = text[m.start():]
    body = body[:body.index("};") + 2]
    count = len(re.findall(r"[-+]?\d+\.\d+", body[body.index("="):]))
    vec = re.search(r"VecBase<\s*float\s*,\s*(\d)\s*>\s*$", text[max(m.start() - 40, 0):m.start()])
    trailing = re.match(r"\w+\s*\[64\]\s*\[64\]\s*\[(\d)\]", body)
    per_row = 64 * int(vec.group(1) if vec else trailing.group(1) if trailing else 2)  # channels per texel
    rows = count // per_row
    data = read_array_text(body, (rows, 64, per_row // 64)).data[..., :2]
    return data, np.arange(first_row, first_row + rows)


def compare_eevee(path: Path, first_row: int, device=None, workers=None) -> dict:
    theirs, rows = eevee_split_sum_rows(path, first_row)
    t = build_preset("eevee-brdf-split-sum", select={"mu": list(rows)}, device=device, workers=workers)
    axes = {"y_row": rows, "roughness": t.axes["roughness"]}
    out = {"engine": "EEVEE", "preset": "eevee-brdf-split-sum", "source": str(path), "rows": [int(rows[0]), int(rows[-1])],
           "mu": [float(t.axes["mu"][0]), float(t.axes["mu"][-1])]}
    for k, ch in enumerate(("A", "B")):
        out[ch] = _stats(np.asarray(t.channels[ch]), theirs[..., k], axes)
    e_ours = np.asarray(t.channels["A"]) + np.asarray(t.channels["B"])
    out["E"] = _stats(e_ours, theirs.sum(axis=-1), axes)
    return out


def materialx_fit(mu: np.ndarray, alpha: np.ndarray, coeffs) -> np.ndarray:
    """MaterialX's rational fit: (A, B) = clamp(r.xy / r.zw, 0, 1), r = sum of coefficient vec4 x term."""
    x, y = np.meshgrid(mu, alpha, indexing="ij")
    terms = [np.ones_like(x), x, y, x * y, x * x, y * y, x * x * y, x * y * y, x * x * y * y]
    r = sum(np.asarray(c, dtype=np.float64)[:, None, None] * t for c, t in zip(coeffs, terms))
    return np.clip(np.stack([r[0] / r[2], r[1] / r[3]], axis=-1), 0.0, 1.0)  # r.z, r.w > 0 on [0, 1]^2


def compare_materialx(path: Path, device=None, workers=None) -> dict:
    spec = json.loads(path.read_text(encoding="utf-8"))
    coeffs = spec["coefficients_vec4_per_term_(r.x, r.y, r.z, r.w)"]
    mu = (np.arange(32) + 0.5) / 32
    alpha = np.arange(32) / 31
    from bsdf_tab import tabulate

    t = tabulate({"table": "dfg", "distribution": "ggx", "shadowing": "correlated", "tolerance": 1e-6,
                  "axes": {"mu": [float(v) for v in mu], "alpha": [float(v) for v in alpha]}},
                 device=device, workers=workers)
    fit = materialx_fit(mu, alpha, coeffs)
    axes = {"mu": mu, "alpha": alpha}
    out = {"engine": "MaterialX", "preset": "(exact dfg, correlated, 32 x 32: mu centres, alpha endpoints)",
           "source": str(path)}
    for k, ch in enumerate(("A", "B")):
        out[ch] = _stats(np.asarray(t.channels[ch]), fit[..., k], axes)
    out["E"] = _stats(np.asarray(t.channels["A"]) + np.asarray(t.channels["B"]), fit.sum(axis=-1), axes)
    return out


def env_brdf_approx(roughness: np.ndarray, nov: np.ndarray) -> np.ndarray:
    """Karis' mobile EnvBRDFApprox (UE4 ``BRDF.ush``; Bevy's ``F_AB``): (A, B) on roughness x NoV."""
    r, n = np.meshgrid(roughness, nov, indexing="ij")
    c0, c1 = (-1.0, -0.0275, -0.572, 0.022), (1.0, 0.0425, 1.04, -0.04)
    rx, ry, rz, rw = (r * a + b for a, b in zip(c0, c1))
    a004 = np.minimum(rx * rx, np.exp2(-9.28 * n)) * rx + ry
    return np.stack([-1.04 * a004 + rz, 1.04 * a004 + rw], axis=-1)


def compare_env_brdf_approx(name: str, device=None, workers=None, reuse=False) -> dict:
    t = _preset_table(name, device, workers, reuse)
    fit = env_brdf_approx(t.axes["roughness"], t.axes["mu"])
    out = {"engine": "Unreal EnvBRDFApprox / Bevy F_AB", "preset": name}
    for k, ch in enumerate(("A", "B")):
        out[ch] = _stats(np.asarray(t.channels[ch]), fit[..., k], dict(t.axes))
    return out


def _radical_inverse(i: np.ndarray) -> np.ndarray:
    b = i.astype(np.uint32)
    b = (b << np.uint32(16)) | (b >> np.uint32(16))
    b = ((b & np.uint32(0x55555555)) << np.uint32(1)) | ((b & np.uint32(0xAAAAAAAA)) >> np.uint32(1))
    b = ((b & np.uint32(0x33333333)) << np.uint32(2)) | ((b & np.uint32(0xCCCCCCCC)) >> np.uint32(2))
    b = ((b & np.uint32(0x0F0F0F0F)) << np.uint32(4)) | ((b & np.uint32(0xF0F0F0F0)) >> np.uint32(4))
    b = ((b & np.uint32(0x00FF00FF)) << np.uint32(8)) | ((b & np.uint32(0xFF00FF00)) >> np.uint32(8))
    return b.astype(np.float64) * 2.3283064365386963e-10


def godot_dfg(size: int = 128, samples: int = 1024) -> tuple[np.ndarray, np.ndarray]:
    """Godot's integrate_dfg.glsl in float64: texture (size, size, 2) = (r, g) rows y, columns x,
    and the roughness each row was computed at, (size - y + 0.5) / size (written from the shader)."""
    i = np.arange(samples)
    xi1, xi2 = i / samples, _radical_inverse(i)
    nov = (np.arange(size) + 0.5) / size
    rough = (size - np.arange(size) + 0.5) / size
    out = np.zeros((size, size, 2))
    vx, vz = np.sqrt(1.0 - nov**2)[:, None], nov[:, None]
    for y, r in enumerate(rough):
        a = r * r
        phi = 2.0 * np.pi * xi1
        cos_t = np.sqrt((1.0 - xi2) / (1.0 + (a * a - 1.0) * xi2))  # denominator >= a^2 > 0
        sin_t = np.sqrt(np.maximum(1.0 - cos_t**2, 0.0))
        hx, hy = np.cos(phi) * sin_t, np.sin(phi) * sin_t
        # tangent frame of N = z with up = (1, 0, 0): tangent (0, -1, 0), bitangent (1, 0, 0)
        wx, wy, wz = hy, -hx, cos_t
        norm = np.sqrt(wx * wx + wy * wy + wz * wz)
        wx, wy, wz = wx / norm, wy / norm, wz / norm
        vdh = vx * wx[None, :] + vz * wz[None, :]  # v = (vx, 0, vz)
        lz = 2.0 * vdh * wz[None, :] - vz
        ndl, ndh, vdh_s = np.clip(lz, 0, 1), np.clip(wz, 0, 1)[None, :], np.clip(vdh, 0, 1)
        k = r * r / 2.0
        g = (vz / (vz * (1 - k) + k)) * (ndl / (ndl * (1 - k) + k))
        g_vis = np.where(ndl > 0, g * vdh_s / np.maximum(ndh * vz, 1e-30), 0.0)  # guard: ndh, NoV > 0 here
        fc = (1.0 - vdh_s) ** 5
        out[y, :, 0] = (fc * g_vis).mean(axis=1)
        out[y, :, 1] = g_vis.mean(axis=1)
    return out.astype(np.float16).astype(np.float64), rough


def compare_godot(device=None, workers=None, reuse=False, samples=1024) -> dict:
    t = _preset_table("godot-dfg", device, workers, reuse)
    theirs, rough = godot_dfg(128, samples)
    axes = dict(t.axes)
    out = {"engine": "Godot", "preset": "godot-dfg", "source": "integrate_dfg.glsl run in NumPy",
           "godot_rows_roughness": [float(rough[0]), float(rough[-1])],
           "preset_rows_roughness": [float(t.axes["roughness"][0]), float(t.axes["roughness"][-1])]}
    for k, ch in enumerate(("B", "E")):
        out[ch] = _stats(np.asarray(t.channels[ch]), theirs[..., k], axes)
    # the same against our exact table at Godot's own (shifted) rows: what the estimator and its G cost
    from bsdf_tab import tabulate

    ex = tabulate({"table": "dfg", "distribution": "ggx", "shadowing": "separable", "tolerance": 1e-6,
                   "axes": {"mu": [float(v) for v in t.axes["mu"]], "roughness": [float(v) for v in np.sort(rough)]}},
                  device=device, workers=workers)
    A, B = (np.asarray(ex.channels[c])[:, ::-1].T for c in ("A", "B"))  # rows as Godot's
    for k, (ch, ours) in enumerate((("B_at_godot_rows", B), ("E_at_godot_rows", A + B))):
        out[ch] = _stats(ours, theirs[..., k], {"roughness": rough, "mu": t.axes["mu"]})
    return out


def gltf_lut(nov: np.ndarray, rough: np.ndarray, samples: int) -> np.ndarray:
    """The glTF Sample Viewer's ``LUT(NdotV, roughness)`` (ibl_filtering.frag) in float64: (A, B) on
    rough x nov; Hammersley u = i/N -> cos theta_h, v = radical inverse -> phi; V_SmithGGXCorrelated."""
    i = np.arange(samples)
    u, v = i / samples, _radical_inverse(i)
    out = np.zeros((len(rough), len(nov), 2))
    vx, vz = np.sqrt(1.0 - nov**2)[:, None], nov[:, None]
    for y, r in enumerate(rough):
        a = r * r
        ct = np.sqrt((1.0 - u) / (1.0 + (a * a - 1.0) * u))  # denominator >= a^2 > 0
        st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))
        hx, hz = st * np.cos(2.0 * np.pi * v), ct  # TBN = identity for N = z
        vdh = vx * hx[None, :] + vz * hz[None, :]
        lz = 2.0 * vdh * hz[None, :] - vz
        ndl, ndh, vdh_s = np.clip(lz, 0, 1), np.clip(hz, 0, 1)[None, :], np.clip(vdh, 0, 1)
        a2 = r**4
        ggxv = ndl * np.sqrt(vz * vz * (1 - a2) + a2)
        ggxl = vz * np.sqrt(ndl * ndl * (1 - a2) + a2)
        vis = 0.5 / np.maximum(ggxv + ggxl, 1e-30)  # guard: both vanish only where ndl = 0 (masked)
        vpdf = np.where(ndl > 0, vis * vdh_s * ndl / np.maximum(ndh, 1e-30), 0.0)
        fc = (1.0 - vdh_s) ** 5
        out[y, :, 0] = 4.0 * ((1.0 - fc) * vpdf).mean(axis=1)
        out[y, :, 1] = 4.0 * (fc * vpdf).mean(axis=1)
    return out


def compare_gltf(samples: int, device=None, workers=None) -> dict:
    idx = list(range(8, 1024, 16))  # every 16th texel of the 1024 x 1024 LUT
    t = build_preset("gltf-ggx-lut", select={"roughness": idx, "mu": idx}, device=device, workers=workers)
    theirs = gltf_lut(np.asarray(t.axes["mu"]), np.asarray(t.axes["roughness"]), samples)
    out = {"engine": "glTF Sample Viewer", "preset": f"gltf-ggx-lut (every 16th texel, {samples} samples)",
           "source": "ibl_filtering.frag LUT() run in NumPy"}
    for k, ch in enumerate(("A", "B")):
        out[ch] = _stats(np.asarray(t.channels[ch]), theirs[..., k], dict(t.axes))
    return out


def _preset_table(name: str, device, workers, reuse: bool) -> Table:
    cached = OUT / "presets" / f"{name}.npz"
    if reuse and cached.exists():
        return Table.from_npz_bytes(cached.read_bytes())
    table = build_preset(name, device=device, workers=workers)
    cached.parent.mkdir(parents=True, exist_ok=True)
    cached.write_bytes(table.to_npz_bytes())
    return table


def run_engines(args, anchors: Path) -> tuple[list, list]:
    rows, skipped = [], []
    if args.eevee_lut:
        path = Path(args.eevee_lut)
        if path.is_file():
            rows.append(compare_eevee(path, args.eevee_first_row, args.device, args.workers))
        else:
            skipped.append({"engine": "EEVEE", "reason": f"{path} not found"})
    else:
        skipped.append({"engine": "EEVEE", "reason": "no --eevee-lut (a copy of Blender's eevee_lut.cc)"})
    mx = Path(args.materialx) if args.materialx else anchors / "materialx" / "mx_ggx_dir_albedo_analytic.json"
    if mx.is_file():
        rows.append(compare_materialx(mx, args.device, args.workers))
    else:
        skipped.append({"engine": "MaterialX", "reason": f"{mx} not found"})
    for name in ("unreal-envbrdf", "bevy-dfg"):
        rows.append(compare_env_brdf_approx(name, args.device, args.workers, args.reuse))
    rows.append(compare_godot(args.device, args.workers, args.reuse, args.godot_samples))
    for n in args.gltf_samples:
        rows.append(compare_gltf(n, args.device, args.workers))
    for r in rows:
        chans = [k for k in r if isinstance(r[k], dict) and "max_abs_diff" in r[k]]
        for ch in chans:
            st = r[ch]
            at = ", ".join(f"{k} {v:.4g}" for k, v in st["max_at"].items())
            print(f"| {r['engine']} | {r['preset']} | {ch} | {st['max_abs_diff']:.3g} ({at}) | {st['mean_abs_diff']:.3g} | "
                  f"{st['mean_signed_theirs_minus_ours']:+.3g} |", flush=True)
    return rows, skipped


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """Parse ``argv`` (default: ``sys.argv[1:]``; ``prog``: the name in the usage line), bake,
    compare and report. ``bsdf-tab bench compare_peers`` calls it."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--only", nargs="*", default=None, help="preset names (default: all with a peer table)")
    parser.add_argument("--reuse", action="store_true", help="reuse bench/out/presets/*.npz")
    parser.add_argument("--engines", action="store_true", help="also compare with the engines' shipped numbers")
    parser.add_argument("--engines-only", action="store_true", help="only the engines' numbers (not the anchors' tables)")
    parser.add_argument("--eevee-lut", metavar="PATH", help="Blender's eevee_lut.cc (or an excerpt of it)")
    parser.add_argument("--eevee-first-row", type=int, default=0, help="the row index of the first row in --eevee-lut")
    parser.add_argument("--materialx", metavar="PATH", help="mx_ggx_dir_albedo_analytic.json (default: the anchors')")
    parser.add_argument("--godot-samples", type=int, default=1024)
    parser.add_argument("--gltf-samples", type=int, nargs="*", default=[512, 1024],
                        help="sample counts of the glTF Sample Viewer's LUT pass to run")
    args = parser.parse_args(argv)
    if args.engines_only:
        args.engines = True

    anchors = anchors_dir()
    engine_rows, engine_skipped = [], []
    if args.engines:
        print("| engine | preset | channel | max abs diff (at) | mean abs diff | mean theirs - ours |")
        print("|---|---|---|---|---|---|")
        engine_rows, engine_skipped = run_engines(args, anchors)
        for s in engine_skipped:
            print(f"skipped {s['engine']}: {s['reason']}")
        OUT.mkdir(parents=True, exist_ok=True)
        (OUT / "compare_engines.json").write_text(json.dumps({"engines": engine_rows, "skipped": engine_skipped,
                                                             "platform": platform.platform()}, indent=1),
                                                 encoding="utf-8")
        print(f"wrote {OUT / 'compare_engines.json'}")
        if args.engines_only:
            return 0
    if not anchors.is_dir():
        print(f"compare_peers: no anchors folder at {anchors} (set BSDF_TAB_ANCHORS); skipping the anchors' tables")
        return 0
    names = [n for n, p in PRESETS.items() if p.anchor and (args.only is None or n in args.only)]
    cache_dir = OUT / "presets"
    cache_dir.mkdir(parents=True, exist_ok=True)
    results, skipped = [], []
    for name in names:
        preset = PRESETS[name]
        anchor = anchors / preset.anchor
        if not anchor.exists():
            skipped.append({"preset": name, "reason": f"{preset.anchor} not in the anchors"})
            continue
        cached = cache_dir / f"{name}.npz"
        t0 = time.perf_counter()
        if args.reuse and cached.exists():
            table = Table.from_npz_bytes(cached.read_bytes())
        else:
            table = build_preset(name, device=args.device, workers=args.workers)
            cached.write_bytes(table.to_npz_bytes())
        seconds = time.perf_counter() - t0
        row = compare(name, table, np.load(anchor).astype(np.float64), anchors)
        row["seconds"] = seconds
        results.append(row)
        print(
            f"{name:<30} max {row['max_abs_diff']:.2e}  mean {row['mean_abs_diff']:.2e}  "
            f"interior max {row['interior_max_abs_diff']:.2e} mean {row['interior_mean_abs_diff']:.2e}  "
            f"bias(theirs-ours) mean {row['mean_signed_theirs_minus_ours']:+.2e} max {row['max_signed_theirs_minus_ours']:+.3f}  "
            f"({seconds:.0f} s)",
            flush=True,
        )
    for name, preset in PRESETS.items():
        if not preset.anchor and (args.only is None or name in args.only):
            skipped.append({"preset": name, "reason": "no peer table in the anchors (conventions only)"})

    print()
    header = "| preset | shape | max abs diff (at) | mean abs diff | interior max / mean | max theirs - ours | our max err |"
    print(header)
    print("|" + "---|" * 7)
    for r in results:
        at = ", ".join(f"{k} {v:.4g}" for k, v in r["max_at"].items())
        print(
            f"| {r['preset']} | {'x'.join(map(str, r['shape']))} | {r['max_abs_diff']:.2e} ({at}) | "
            f"{r['mean_abs_diff']:.2e} | {r['interior_max_abs_diff']:.2e} / {r['interior_mean_abs_diff']:.2e} | "
            f"{r['max_signed_theirs_minus_ours']:+.3f} | {r['our_max_error_estimate']:.1e} |"
        )
    for s in skipped:
        print(f"skipped {s['preset']}: {s['reason']}")
    OUT.mkdir(parents=True, exist_ok=True)
    report = {
        "engines": engine_rows,
        "engines_skipped": engine_skipped,
        "anchors": str(anchors),
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "results": results,
        "skipped": skipped,
    }
    (OUT / "compare_peers.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    print(f"wrote {OUT / 'compare_peers.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
