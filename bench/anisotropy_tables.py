"""The smallest ``albedo_aniso`` table under a lookup-error target, per domain.

Run: ``python bench/anisotropy_tables.py [--domain MU_MIN,R_MIN ...] [--quick] [--tol 1e-3]``.

For each domain (mu in [mu_min, 1], roughness in [r_min, 1], phi_v in [0, pi/2], anisotropy a in
[0, 1]) one master grid is computed with ``albedo_aniso_values`` (the table's own kernel):

- mu: ``square`` spacing (uniform in sqrt(mu)), the spec's own spacing;
- phi_v: nodes phi_k = (pi/2) (1 - (1 - s_k)^2), s_k uniform on [0, 1] (E is even about both ends of
  [0, pi/2], so nodes at both ends suffice; clustered toward pi/2, where a view along the smooth
  direction changes the projected width sqrt(alpha_x^2 cos^2 + alpha_y^2 sin^2) within
  ~alpha_y / alpha_x radians: an explicit ``phi_v`` value list; a shader looks it up at
  s = 1 - sqrt(1 - 2 phi_v / pi));
- roughness: linear (alpha = r^2), or ``--r-spacing square`` (uniform in sqrt(r): the spec's
  ``square`` spacing, denser at the roughness floor);
- anisotropy: nodes uniform in t = log10(alpha_x / alpha_y) = -log10(1 - 0.9 a), i.e.
  a_k = (1 - 10^(-t_k)) / 0.9 (an explicit ``anisotropy`` value list in a spec; a shader looks it up
  at t = -log10(1 - 0.9 a)): the aspect ratio is hyperbolic in a, so linear nodes crowd the wrong end.

Every sub-grid of 2^k + 1 nodes per axis is then a candidate table. Its multilinear lookup (in the
axes' own coordinates: sqrt(mu), s, r, t) is compared at off-grid points against values
computed directly by the kernel at those points (not from any table): random points uniform in
those coordinates plus points pinned at the domain's hard edges (a = 1, mu = mu_min, r = r_min).
Two stored quantities: E itself, and the ratio E / E_iso(mu, alpha) looked up and multiplied by
the isotropic table E_iso(mu, alpha) on the same (mu, roughness) nodes (so the isotropic table's
own lookup error is included). Prints the smallest table per domain and quantity whose max lookup
error is under ``--tol``, writes ``bench/out/anisotropy_tables.json`` (grids cached in
``bench/out/anisotropy_grid_*.npz``).
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

from bsdf_tab.api import quiet_warp  # noqa: E402
from bsdf_tab.model.ggx_aniso import aniso_widths  # noqa: E402
from bsdf_tab.tables.aniso import albedo_aniso_values  # noqa: E402

MASTER = (9, 33, 17, 9)
QUICK = (5, 5, 5, 5)


def aniso_of_t(t):
    """a with log10(aspect) = t: aspect = 1 / (1 - 0.9 a)."""
    return (1.0 - 10.0 ** (-np.asarray(t, dtype=np.float64))) / 0.9


def t_of_aniso(a):
    return -np.log10(1.0 - 0.9 * np.asarray(a, dtype=np.float64))  # 1 - 0.9 a >= 0.1


def phi_of_s(s):
    """phi_v nodes clustered toward pi/2: phi = (pi/2) (1 - (1 - s)^2)."""
    return 0.5 * math.pi * (1.0 - (1.0 - np.asarray(s, dtype=np.float64)) ** 2)


def s_of_phi(phi):
    return 1.0 - np.sqrt(np.clip(1.0 - np.asarray(phi, dtype=np.float64) / (0.5 * math.pi), 0.0, 1.0))  # phi <= pi/2


R_SPACING = {"linear": (lambda r: r, lambda q: q), "square": (np.sqrt, np.square)}  # (coordinate, back)


def coords(mu_min: float, r_min: float, n, t_max: float = 1.0, r_spacing: str = "linear"):
    """Master-grid nodes in lookup coordinates (sqrt(mu), s, q(r), t) and in table values."""
    fwd, back = R_SPACING[r_spacing]
    w = np.linspace(math.sqrt(mu_min), 1.0, n[0])
    s = np.linspace(0.0, 1.0, n[1])
    q = np.linspace(float(fwd(r_min)), 1.0, n[2])
    t = np.linspace(0.0, t_max, n[3])
    return (w, s, q, t), (w * w, phi_of_s(s), back(q), aniso_of_t(t))


def evaluate(mu, phi, r, a):
    ax, ay = aniso_widths(np.asarray(r) ** 2, a)
    return albedo_aniso_values(mu, phi, ax, ay)


def multilinear(grid_axes, values, points):
    """Multilinear interpolation of ``values`` on ``grid_axes`` at ``points`` (N, d), clamped to the grid."""
    idx, frac = [], []
    for k, ax in enumerate(grid_axes):
        x = np.clip(points[:, k], ax[0], ax[-1])
        j = np.clip(np.searchsorted(ax, x, side="right") - 1, 0, len(ax) - 2)
        idx.append(j)
        frac.append((x - ax[j]) / (ax[j + 1] - ax[j]))  # strictly increasing nodes
    out = np.zeros(points.shape[0])
    for corner in itertools.product((0, 1), repeat=len(grid_axes)):
        w = np.ones(points.shape[0])
        ii = []
        for k, c in enumerate(corner):
            w = w * (frac[k] if c else 1.0 - frac[k])
            ii.append(idx[k] + c)
        out += w * values[tuple(ii)]
    return out


def test_points(mu_min: float, r_min: float, n_random: int, n_edge: int, seed: int = 17, t_max: float = 1.0):
    """Off-grid points (sqrt(mu), phi_v, r, t), uniform in each (phi_v uniform in angle): random,
    and pinned to the domain's hard edges (t = t_max, mu = mu_min, r = r_min)."""
    rng = np.random.default_rng(seed)
    lo = np.array([math.sqrt(mu_min), 0.0, r_min, 0.0])
    hi = np.array([1.0, math.pi / 2, 1.0, t_max])
    pts = [lo + (hi - lo) * rng.random((n_random, 4))]
    for k, value in ((3, t_max), (0, lo[0]), (2, r_min)):
        p = lo + (hi - lo) * rng.random((n_edge, 4))
        p[:, k] = value
        pts.append(p)
    return np.vstack(pts)


def master_grid(mu_min: float, r_min: float, n, quick: bool, t_max: float = 1.0, r_spacing: str = "linear"):
    tag = f"{mu_min:g}_{r_min:g}_{t_max:.4g}_{'x'.join(map(str, n))}_phi2" + ("" if r_spacing == "linear" else f"_r{r_spacing}")
    path = OUT / f"anisotropy_grid_{tag}.npz"
    cx, vx = coords(mu_min, r_min, n, t_max, r_spacing)
    if path.exists() and not quick:
        d = np.load(path)
        return cx, d["E"], d["E_err"], d["E_iso"], 0.0
    t0 = time.time()
    M, P, R, A = np.meshgrid(*vx, indexing="ij")
    E, E_err = evaluate(M, P, R, A)
    Mi, Ri = np.meshgrid(vx[0], vx[2], indexing="ij")
    E_iso, _ = evaluate(Mi, 0.0, Ri, 0.0)
    seconds = time.time() - t0
    if not quick:
        OUT.mkdir(parents=True, exist_ok=True)
        np.savez(path, E=E, E_err=E_err, E_iso=E_iso)
    return cx, E, E_err, E_iso, seconds


def study(mu_min: float, r_min: float, n, n_random: int, n_edge: int, tol: float, quick: bool,
          a_max: float = 1.0, r_spacing: str = "linear") -> dict:
    t_max = float(t_of_aniso(a_max))
    cx, G, G_err, G_iso, seconds = master_grid(mu_min, r_min, n, quick, t_max, r_spacing)
    raw = test_points(mu_min, r_min, n_random, n_edge, t_max=t_max)
    truth, truth_err = evaluate(raw[:, 0] ** 2, raw[:, 1], raw[:, 2], aniso_of_t(raw[:, 3]))
    pts = raw.copy()
    pts[:, 1] = s_of_phi(raw[:, 1])  # lookup coordinate of phi_v
    pts[:, 2] = R_SPACING[r_spacing][0](raw[:, 2])  # and of roughness
    ratio = G / G_iso[:, None, :, None]  # E_iso > 0 on the domain (E_iso >= 1 - ln 2 > 0.3 for alpha <= 1)
    sizes = [[s for s in (2, 3, 5, 9, 17, 33) if s <= nk and (nk - 1) % (s - 1) == 0] for nk in n]
    results = []
    for s in itertools.product(*sizes):
        st = [(nk - 1) // (sk - 1) for nk, sk in zip(n, s)]
        axes = [c[::k] for c, k in zip(cx, st)]
        sub = (slice(None, None, st[0]), slice(None, None, st[1]), slice(None, None, st[2]), slice(None, None, st[3]))
        e_direct = np.abs(multilinear(axes, G[sub], pts) - truth)
        iso = multilinear([axes[0], axes[2]], G_iso[::st[0], ::st[2]], pts[:, [0, 2]])
        e_ratio = np.abs(multilinear(axes, ratio[sub], pts) * iso - truth)
        for quantity, err in (("E", e_direct), ("ratio", e_ratio)):
            worst = int(np.argmax(err))
            results.append({
                "quantity": quantity, "size": list(s), "texels": int(np.prod(s)), "max_err": float(err.max()),
                "p99_err": float(np.quantile(err, 0.99)), "mean_err": float(err.mean()),
                "worst_at": {"mu": float(pts[worst, 0] ** 2), "phi_v": float(raw[worst, 1]),
                             "roughness": float(pts[worst, 2]), "anisotropy": float(aniso_of_t(pts[worst, 3]))},
            })
    best = {}
    for quantity in ("E", "ratio"):
        ok = sorted((r for r in results if r["quantity"] == quantity and r["max_err"] < tol), key=lambda r: r["texels"])
        best[quantity] = ok[0] if ok else None
    finest = [r for r in results if r["size"] == list(n)]
    return {"mu_min": mu_min, "r_min": r_min, "a_max": a_max, "r_spacing": r_spacing, "master": list(n), "master_seconds": seconds,
            "master_max_E_err": float(G_err.max()), "points": int(len(pts)), "points_max_E_err": float(truth_err.max()),
            "best": best, "finest": finest, "tables": results}


def main(argv=None, prog=None) -> int:
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    ap.add_argument("--domain", action="append", default=None, metavar="MU_MIN,R_MIN[,A_MAX]",
                    help="a domain (repeat); default: 0.1,0.2 and 0.05,0.1 and 0.1,0.2,0.8")
    ap.add_argument("--tol", type=float, default=1e-3, help="max lookup error (default 1e-3)")
    ap.add_argument("--quick", action="store_true", help="a coarse master grid (CI smoke run)")
    ap.add_argument("--out", default="anisotropy_tables.json", help="JSON file name under bench/out/")
    ap.add_argument("--master", default=None, metavar="NMU,NPHI,NR,NT", help="master grid sizes (2^k + 1 each)")
    ap.add_argument("--r-spacing", default="linear", choices=tuple(R_SPACING), help="roughness nodes (square: uniform in sqrt(r))")
    args = ap.parse_args(argv)
    quiet_warp()
    domains = [tuple(float(x) for x in d.split(",")) for d in (args.domain or ["0.1,0.2", "0.05,0.1", "0.1,0.2,0.8"])]
    n = QUICK if args.quick else (tuple(int(x) for x in args.master.split(",")) if args.master else MASTER)
    out = []
    for dom in domains:
        mu_min, r_min, a_max = (*dom, 1.0)[:3]
        res = study(mu_min, r_min, n, 60 if args.quick else 1200, 20 if args.quick else 200, args.tol, args.quick, a_max,
                    args.r_spacing)
        out.append(res)
        print(f"domain mu >= {mu_min:g}, roughness >= {r_min:g}, a <= {a_max:g}: master {n} ({res['master_seconds']:.0f} s), "
              f"max E_err {res['master_max_E_err']:.1e} (points {res['points_max_E_err']:.1e})")
        for quantity in ("E", "ratio"):
            b = res["best"][quantity]
            fin = next(r for r in res["finest"] if r["quantity"] == quantity)
            text = (f"{tuple(b['size'])} = {b['texels']} texels, max {b['max_err']:.2e}" if b else
                    f"none; finest {tuple(fin['size'])} max {fin['max_err']:.2e} at {fin['worst_at']}")
            print(f"  {quantity:5s} smallest under {args.tol:g}: {text}")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / Path(args.out).name).write_text(json.dumps({"tol": args.tol, "quick": args.quick, "domains": out}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
