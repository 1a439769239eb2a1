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
3. the same furnace with the compensation looked up in a real isotropic table (32 x 32, linear
   mu and roughness, bilinear; its lookup error adds to the collapse). The smallest
   ``albedo_aniso`` table under 1e-3 is ``bench/anisotropy_tables.py``.

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


def main(argv=None, prog=None) -> int:
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
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

    # 2b: the white furnace with the engines' compensation from an isotropic *table* (32 x 32,
    # mu and roughness linear with end nodes, bilinear lookup at the collapse): Kulla-Conty adds
    # 1 - E_tab(mu_i) (with E_avg taken from the same table), so the furnace is
    # 1 + E_aniso - E_tab; the multiplicative 1 / E_tab gives E_aniso / E_tab
    tab = bsdf_tab.tabulate({"table": "albedo", "axes": {"mu": {"size": 32}, "roughness": {"size": 32}}})
    g = np.linspace(0.0, 1.0, 32)
    pts = np.column_stack([M.ravel(), R.ravel()])
    E_tab = multilinear([g, g], np.asarray(tab.channels["E"], dtype=np.float64), pts).reshape(M.shape)
    furnace_kc = 1.0 + E - E_tab
    furnace_mult = E / E_tab  # E_tab >= 0.3 for roughness <= 1
    print(f"white furnace, Kulla-Conty with the 32 x 32 isotropic table: min {furnace_kc.min():.4f}, "
          f"max {furnace_kc.max():.4f} (at a = 0: {furnace_kc[..., 0].min():.5f} .. {furnace_kc[..., 0].max():.5f}); "
          f"multiplicative: {furnace_mult.min():.4f} .. {furnace_mult.max():.4f}")
    print("the smallest albedo_aniso table under 1e-3: bench/anisotropy_tables.py")
    OUT.mkdir(parents=True, exist_ok=True)
    data = {"mu": mu.tolist(), "phi_v": phi.tolist(), "roughness": rough.tolist(), "anisotropy": an.tolist(),
            "collapse_max_by_roughness_a": rows, "E_aniso": E.tolist(), "E_iso": iso.channels["E"].tolist(),
            "max_E_err": float(E_err.max()), "furnace_kc_min": float(furnace_kc.min()),
            "furnace_kc_max": float(furnace_kc.max()), "furnace_mult_min": float(furnace_mult.min()),
            "furnace_mult_max": float(furnace_mult.max()),
            "furnace_kc_min_by_roughness_a": furnace_kc.min(axis=(0, 1)).tolist(), "quick": args.quick}
    (OUT / "anisotropy.json").write_text(json.dumps(data, indent=1))
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axs = plt.subplots(1, 3, figsize=(15, 4))
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
        for k, r in enumerate(rough):
            line = axs[2].plot(an, furnace_kc[:, :, k, :].min(axis=(0, 1)), marker="o", label=f"roughness {r:.1f}")
            axs[2].plot(an, furnace_mult[:, :, k, :].min(axis=(0, 1)), ls=":", color=line[0].get_color())
        axs[2].axhline(1.0, color="k", lw=0.5)
        axs[2].set_xlabel("anisotropy a")
        axs[2].set_ylabel("white furnace energy (min over mu, phi_v)")
        axs[2].set_title("compensated with the 32 x 32 isotropic table\nsolid: Kulla-Conty, dotted: 1 / E_iso", fontsize=9)
        axs[2].legend(fontsize=7)
        fig.tight_layout()
        (ROOT / "docs" / "img").mkdir(parents=True, exist_ok=True)
        fig.savefig(ROOT / "docs" / "img" / "anisotropy.png", dpi=110)
    except ImportError:
        pass
    print(f"total {time.time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
