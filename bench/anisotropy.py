"""How wrong is the isotropic collapse of anisotropic GGX albedo?

Run: ``python bench/anisotropy.py [--quick]``.

Anisotropy a in [0, 1], alpha_x = alpha / sqrt(1 - 0.9 a), alpha_y = alpha sqrt(1 - 0.9 a) (so
sqrt(alpha_x alpha_y) = alpha: the collapse every engine uses is the isotropic table at alpha),
correlated Smith shadowing, F = 1. For a grid of (mu, phi_v, alpha = roughness^2, a):

1. collapse error: E_aniso(mu, phi_v, alpha_x, alpha_y) - E_iso(mu, alpha) (``albedo_aniso``
   and ``albedo``, both with error channels far below the differences shown);
2. white furnace after Kulla-Conty compensation with the isotropic tables (Kulla and Conty
   2017, "Revisiting Physically Based Shading at Imageworks"): the added lobe
   f_ms = (1 - E_iso(mu_i)) (1 - E_iso(mu_o)) / (pi (1 - E_avg_iso)) returns exactly
   1 - E_iso(mu_i), so the furnace is 1 + (E_aniso - E_iso): the same number; with the
   multiplicative compensation f / E_iso (Cycles, Filament's energy scale) it is
   E_aniso / E_iso;
3. the smallest ``albedo_aniso`` table (square spacing in mu, linear nodes in phi_v in
   [0, pi/2], roughness and anisotropy; multilinear lookup) whose lookup error at random points
   (mu in [0.01, 1], uniform in sqrt(mu)) stays under 1e-3, among sub-grids of one computed grid.

Prints tables, writes ``bench/out/anisotropy.json`` and ``docs/img/anisotropy.png``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "bench" / "out"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bsdf_tab  # noqa: E402
from bsdf_tab.api import quiet_warp  # noqa: E402
from bsdf_tab.model.ggx_aniso import aniso_widths  # noqa: E402
from bsdf_tab.tables.aniso import albedo_aniso_values  # noqa: E402


def multilinear(grid_axes, values, points):
    """Multilinear interpolation of ``values`` on ``grid_axes`` at ``points`` (N, d)."""
    idx, frac = [], []
    for k, ax in enumerate(grid_axes):
        j = np.clip(np.searchsorted(ax, points[:, k], side="right") - 1, 0, len(ax) - 2)
        idx.append(j)
        frac.append((points[:, k] - ax[j]) / (ax[j + 1] - ax[j]))
    out = np.zeros(points.shape[0])
    for corner in itertools.product((0, 1), repeat=len(grid_axes)):
        w = np.ones(points.shape[0])
        ii = []
        for k, c in enumerate(corner):
            w *= frac[k] if c else 1.0 - frac[k]
            ii.append(idx[k] + c)
        out += w * values[tuple(ii)]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a coarse grid (CI smoke run)")
    args = ap.parse_args(argv)
    quiet_warp()
    t0 = time.time()
    # 1-2: the collapse over a grid
    mu = np.array([0.05, 0.2, 0.5, 0.8, 1.0]) if args.quick else np.array([0.02, 0.1, 0.25, 0.5, 0.75, 1.0])
    phi = np.linspace(0, math.pi / 2, 3 if args.quick else 5)
    rough = np.array([0.3, 0.6, 1.0]) if args.quick else np.array([0.2, 0.4, 0.6, 0.8, 1.0])
    an = np.array([0.0, 0.5, 1.0]) if args.quick else np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    M, P, R, A = np.meshgrid(mu, phi, rough, an, indexing="ij")
    ax, ay = aniso_widths(R**2, A)
    E, E_err = albedo_aniso_values(M, P, ax, ay)
    iso = bsdf_tab.tabulate({"table": "albedo", "axes": {"mu": mu.tolist(), "roughness": rough.tolist()}})
    Ei = iso.channels["E"][:, None, :, None]
    diff = E - Ei
    ratio = E / Ei
    print(f"collapse E_aniso - E_iso (max |.| over mu and phi_v), {time.time() - t0:.0f} s; max E_err {E_err.max():.1e}")
    print("roughness \\ a " + "".join(f"{a:>9.2f}" for a in an))
    rows = []
    for k, r in enumerate(rough):
        worst = np.abs(diff[:, :, k, :]).max(axis=(0, 1))
        rows.append(worst.tolist())
        print(f"{r:>14.2f}" + "".join(f"{w:9.4f}" for w in worst))
    print("at a = 1, by phi_v (max over mu, roughness): " +
          ", ".join(f"{p:.2f}: {np.abs(diff[:, j, :, -1]).max():.4f}" for j, p in enumerate(phi)))
    print(f"furnace with multiplicative 1/E_iso: max |E_aniso/E_iso - 1| = {np.abs(ratio - 1).max():.4f}")

    # 3: smallest table with lookup error < 1e-3 (sub-grids of one grid of 2^k + 1 nodes)
    n = (5, 3, 5, 3) if args.quick else (17, 5, 9, 5)
    g_mu = np.linspace(0, 1, n[0]) ** 2  # square spacing in mu (Unity's sqrt(NdotV) axis): the grazing layer
    g_phi = np.linspace(0, math.pi / 2, n[1])
    g_r = np.linspace(0, 1, n[2])
    g_a = np.linspace(0, 1, n[3])
    GM, GP, GR, GA = np.meshgrid(g_mu, g_phi, g_r, g_a, indexing="ij")
    gx, gy = aniso_widths(GR**2, GA)
    t1 = time.time()
    G, G_err = albedo_aniso_values(GM, GP, gx, gy)
    rng = np.random.default_rng(17)
    npts = 60 if args.quick else 200
    pts = np.column_stack([rng.uniform(0.1, 1, npts) ** 2,  # mu in [0.01, 1], uniform in sqrt(mu)
 rng.uniform(0, math.pi / 2, npts), rng.uniform(0, 1, npts),
                           rng.uniform(0, 1, npts)])
    px, py = aniso_widths(pts[:, 2] ** 2, pts[:, 3])
    truth, _ = albedo_aniso_values(pts[:, 0], pts[:, 1], px, py)
    iso_pts = bsdf_tab.tabulate({"table": "albedo", "axes": {"mu": g_mu.tolist(), "roughness": g_r.tolist()}})
    print(f"grid {n} in {time.time() - t1:.0f} s")
    results = []
    sizes = [[s for s in (2, 3, 5, 9, 17) if s <= nk and (nk - 1) % (s - 1) == 0] for nk in n]
    for s in itertools.product(*sizes):
        steps = [(nk - 1) // (sk - 1) for nk, sk in zip(n, s)]
        sub = G[::steps[0], ::steps[1], ::steps[2], ::steps[3]]
        axes = [g_mu[::steps[0]], g_phi[::steps[1]], g_r[::steps[2]], g_a[::steps[3]]]
        err = np.abs(multilinear(axes, sub, pts) - truth)
        results.append({"size": list(s), "texels": int(np.prod(s)), "max_err": float(err.max()),
                        "p99_err": float(np.quantile(err, 0.99))})
    # the collapse itself at the random points, with the finest isotropic (mu, roughness) table
    iso_lookup = multilinear([g_mu, g_r], iso_pts.channels["E"], pts[:, [0, 2]])
    collapse = np.abs(iso_lookup - truth)
    ok = sorted((r for r in results if r["max_err"] < 1e-3), key=lambda r: r["texels"])
    print(f"collapse at random points (isotropic {n[0]} x {n[2]} table): max {collapse.max():.4f}, "
          f"p99 {np.quantile(collapse, 0.99):.4f}")
    print("smallest albedo_aniso tables (mu, phi_v, roughness, a) by lookup max error:")
    for r in sorted(results, key=lambda r: r["texels"])[-8:]:
        print(f"  {str(tuple(r['size'])):18} {r['texels']:6d} texels  max {r['max_err']:.2e}  p99 {r['p99_err']:.2e}")
    best = ok[0] if ok else None
    print("smallest under 1e-3:", best)
    OUT.mkdir(parents=True, exist_ok=True)
    data = {"mu": mu.tolist(), "phi_v": phi.tolist(), "roughness": rough.tolist(), "anisotropy": an.tolist(),
            "collapse_max_by_roughness_a": rows, "E_aniso": E.tolist(), "E_iso": iso.channels["E"].tolist(),
            "max_E_err": float(E_err.max()), "grid": list(n), "tables": results, "smallest_under_1e-3": best,
            "collapse_random_max": float(collapse.max()), "quick": args.quick}
    (OUT / "anisotropy.json").write_text(json.dumps(data, indent=1))
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axs = plt.subplots(1, 2, figsize=(10, 4))
        for k, r in enumerate(rough):
            axs[0].plot(an, np.abs(diff[:, :, k, :]).max(axis=(0, 1)), marker="o", label=f"roughness {r:.1f}")
        axs[0].axhline(1e-3, color="k", lw=0.5, ls="--")
        axs[0].set_yscale("log")
        axs[0].set_xlabel("anisotropy a")
        axs[0].set_ylabel("max over mu, phi_v of |E_aniso - E_iso|")
        axs[0].legend(fontsize=7)
        kr = len(rough) - 1
        im = axs[1].imshow(diff[:, :, kr, -1], aspect="auto", origin="lower", cmap="RdBu_r",
                           extent=[phi[0], phi[-1], 0, len(mu)])
        axs[1].set_yticks(np.arange(len(mu)) + 0.5, [f"{m:.2f}" for m in mu])
        axs[1].set_xlabel("phi_v (from the tangent)")
        axs[1].set_ylabel("mu")
        axs[1].set_title(f"E_aniso - E_iso, roughness {rough[kr]:.1f}, a = 1")
        fig.colorbar(im, ax=axs[1])
        fig.tight_layout()
        (ROOT / "docs" / "img").mkdir(parents=True, exist_ok=True)
        fig.savefig(ROOT / "docs" / "img" / "anisotropy.png", dpi=110)
    except ImportError:
        pass
    print(f"total {time.time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
