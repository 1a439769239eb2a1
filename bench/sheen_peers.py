"""Our sheen albedo against engines' published sheen numbers (fits recomputed from their coefficients,
tables read from a file the user gives).

Run: ``python bench/sheen_peers.py [--table PATH ...] [--quick]``.

Peers (the coefficients are facts of their public sources; the formulas are written here):

- MaterialX ``mx_imageworks_sheen_dir_albedo_curve_fit`` (AcademySoftwareFoundation/MaterialX,
  libraries/pbrlib/genglsl/lib/mx_microfacet_sheen.glsl): a rational fit in (NdotV, roughness),
  E = P(c, r) / Q(c, r) with P, Q quadratic (coefficients below), clamped to [0, 1]. MaterialX's
  convention: Charlie D with alpha = roughness itself (``1 / max(roughness, 0.005)``, no square),
  the Neubelt visibility 1 / (4 (NdotL + NdotV - NdotL NdotV)), unclamped: our ``sheen_albedo``
  with ``sheen_shadowing = ashikhmin`` and an ``alpha`` axis = roughness, clamped to [0, 1].
- three.js ``IBLSheenBRDF`` (src/renderers/shaders/ShaderChunk/, two versions are public):
  fit A: E = clamp(exp(a c + b), 0, 1), a and b quadratic in r plus a 1 / (r + 0.1) term;
  fit B (older): E = clamp((exp(a c + b) + [r >= 1/4] (r - 1/4) / 10) / pi, 0, 1), a and b
  quadratic in r, piecewise at r = 1/4. three.js' convention: D_Charlie with alpha = r^2,
  V_Neubelt clamped to [0, 1] (the clamp acts only where NdotL + NdotV - NdotL NdotV < 1/4, never
  for NdotV >= 1/4): our ``ashikhmin`` with a ``roughness`` axis, compared on mu >= 1/4 and on all mu.
- ``--table PATH[,r|r2]``: a 16 x 16 sheen albedo table as the older MaterialX GLSL's
  ``u_sheenAlbedo`` (rows: roughness j / 15, columns: cosTheta i / 15, Neubelt V, alpha =
  roughness (``r``) or roughness^2 (``r2``); a text file of 256 numbers, or .npy): compared at its
  nodes (roughness row 0 is skipped: alpha = 0 has no density; clamped to [0, 1] as its lookup
  does, and unclamped for NdotV >= 1/4) and through its bilinear lookup at the cell midpoints.
  Skipped when not given.

Prints max / mean |E_peer - E_ours| and where, writes ``bench/out/sheen_peers.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "bench" / "out"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bsdf_tab.api import quiet_warp  # noqa: E402
from bsdf_tab.tables.sheen import sheen_albedo_values  # noqa: E402

# MaterialX mx_imageworks_sheen_dir_albedo_curve_fit: (numerator, denominator) coefficients of
# 1, c, r, c r, c^2, r^2 (c = NdotV, r = roughness)
MX_NUM = (13.67300, -68.78018, 799.08825, -905.00061, 60.28956, 1086.96473)
MX_DEN = (1.0, 61.57746, 442.78211, 2597.49308, 121.81241, 3045.55075)
# three.js IBLSheenBRDF fit A: a = a0 + a1 r + a2 r^2 + a3 / (r + 0.1), b likewise
THREE_A = ((-1.9362, 1.0678, 0.4573, -0.8469), (-0.6014, 0.5538, -0.4670, -0.1255))
# fit B (older): for r < 1/4 and r >= 1/4, a = a2 r^2 + a1 r + a0, b = b2 r^2 + b1 r + b0
THREE_B = {"lo": ((-339.2, 161.4, -25.9), (44.0, -23.7, 3.26)), "hi": ((-8.48, 14.3, -9.95), (1.97, -3.27, 0.72))}


def materialx_fit(c, r):
    terms = [np.ones_like(c), c, r, c * r, c * c, r * r]
    num = sum(k * t for k, t in zip(MX_NUM, terms))
    den = sum(k * t for k, t in zip(MX_DEN, terms))  # >= 1 on [0, 1]^2 (all coefficients of den > 0)
    return np.clip(num / den, 0.0, 1.0)


def three_fit_a(c, r):
    (a0, a1, a2, a3), (b0, b1, b2, b3) = THREE_A
    inv = 1.0 / (r + 0.1)  # r >= 0
    return np.clip(np.exp((a0 + a1 * r + a2 * r * r + a3 * inv) * c + (b0 + b1 * r + b2 * r * r + b3 * inv)), 0.0, 1.0)


def three_fit_b(c, r):
    lo = r < 0.25
    (a2l, a1l, a0l), (b2l, b1l, b0l) = THREE_B["lo"]
    (a2h, a1h, a0h), (b2h, b1h, b0h) = THREE_B["hi"]
    a = np.where(lo, a2l * r * r + a1l * r + a0l, a2h * r * r + a1h * r + a0h)
    b = np.where(lo, b2l * r * r + b1l * r + b0l, b2h * r * r + b1h * r + b0h)
    dg = np.exp(a * c + b) + np.where(lo, 0.0, 0.1 * (r - 0.25))
    return np.clip(dg / math.pi, 0.0, 1.0)


def stats(peer, ours, mu, rough, mask=None):
    d = np.abs(peer - ours)
    if mask is not None:
        d = np.where(mask, d, np.nan)
    k = np.unravel_index(np.nanargmax(d), d.shape)
    return {"max": float(np.nanmax(d)), "mean": float(np.nanmean(d)), "at_mu": float(mu[k]), "at_roughness": float(rough[k]),
            "peer": float(peer[k]), "ours": float(ours[k])}


def read_table(path: Path) -> np.ndarray:
    if path.suffix == ".npy":
        t = np.load(path, allow_pickle=False)
    else:
        t = np.array([float(x) for x in path.read_text().replace(",", " ").split()])
    return np.asarray(t, dtype=np.float64).reshape(16, 16)  # [roughness j, cosTheta i]


def main(argv=None, prog=None) -> int:
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    ap.add_argument("--table", action="append", default=[], metavar="PATH[,r|r2]",
                    help="a 16 x 16 MaterialX-style sheen table and its alpha convention (alpha = roughness: r, "
                    "default; alpha = roughness^2: r2); repeat")
    ap.add_argument("--quick", action="store_true", help="a coarse grid")
    args = ap.parse_args(argv)
    quiet_warp()
    n = 9 if args.quick else 32
    c = (np.arange(n) + 0.5) / n  # texel centres in NdotV and roughness
    r = c.copy()
    C, R = np.meshgrid(c, r, indexing="ij")
    res = {"grid": f"{n} x {n} texel centres in (NdotV, roughness)"}
    # MaterialX: alpha = roughness, Neubelt V unclamped, E clamped to [0, 1]
    E_mx, err_mx = sheen_albedo_values(C, R, "ashikhmin")
    ours_mx = np.clip(E_mx, 0.0, 1.0)
    res["materialx_fit"] = stats(materialx_fit(C, R), ours_mx, C, R)
    res["materialx_fit_mu_ge_0.25"] = stats(materialx_fit(C, R), ours_mx, C, R, C >= 0.25)
    # three.js: alpha = r^2, V_Neubelt clamped (no effect for NdotV >= 1/4), E clamped to [0, 1]
    E_3, err_3 = sheen_albedo_values(C, R * R, "ashikhmin")
    ours_3 = np.clip(E_3, 0.0, 1.0)
    for name, fit in (("threejs_fit_a", three_fit_a), ("threejs_fit_b", three_fit_b)):
        res[name + "_mu_ge_0.25"] = stats(fit(C, R), ours_3, C, R, C >= 0.25)
        res[name] = stats(fit(C, R), ours_3, C, R)
    res["max_E_err"] = float(max(err_mx.max(), err_3.max()))
    for item in args.table:
        text, _, conv = str(item).partition(",")
        path, conv = Path(text), conv or "r"
        if conv not in ("r", "r2"):
            print(f"table {item}: the alpha convention must be r or r2, skipped")
            continue
        if not path.exists():
            print(f"table {path}: not found, skipped")
            continue
        T = read_table(path)
        alpha = (lambda x: x) if conv == "r" else (lambda x: x * x)
        nodes = np.arange(16) / 15.0
        Rn, Cn = np.meshgrid(nodes[1:], nodes, indexing="ij")  # rows roughness >= 1/15
        E_n, _ = sheen_albedo_values(Cn, alpha(Rn), "ashikhmin")
        key = f"table:{path.name}(alpha={'roughness' if conv == 'r' else 'roughness^2'})"
        res[key + ":nodes"] = stats(np.clip(T[1:], 0, 1), np.clip(E_n, 0, 1), Cn, Rn)
        res[key + ":nodes_mu_ge_0.25"] = stats(T[1:], E_n, Cn, Rn, Cn >= 0.25)
        mid = (np.arange(15) + 0.5) / 15.0  # bilinear lookup at the cell midpoints, as mx_microfacet_sheen_albedo
        Rm, Cm = np.meshgrid(mid[1:], mid, indexing="ij")
        look = 0.25 * (T[1:-1, :-1] + T[1:-1, 1:] + T[2:, :-1] + T[2:, 1:])
        E_m, _ = sheen_albedo_values(Cm, alpha(Rm), "ashikhmin")
        res[key + ":lookup_midpoints"] = stats(np.clip(look, 0, 1), np.clip(E_m, 0, 1), Cm, Rm)
    if not args.table:
        print("no --table given: the 16 x 16 table comparison is skipped")
    print(f"{'peer':34s} {'max':>8s} {'mean':>8s}  where (NdotV, roughness): peer / ours")
    for k, v in res.items():
        if isinstance(v, dict):
            print(f"{k:34s} {v['max']:8.4f} {v['mean']:8.4f}  ({v['at_mu']:.3f}, {v['at_roughness']:.3f}): "
                  f"{v['peer']:.4f} / {v['ours']:.4f}")
    print(f"our error estimate (max over the grid): {res['max_E_err']:.1e}")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "sheen_peers.json").write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
